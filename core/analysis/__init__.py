"""Analyses of a model: static equilibrium, linearisation, modes and buckling, state space and
principal gains, stresses, model reduction."""
