"""Mechanics on the plain-numpy reference path: assembly of the elements, kinematics (x = F(q), DF,
D2F), the exact-constraint check, forces and stiffness, energy."""
