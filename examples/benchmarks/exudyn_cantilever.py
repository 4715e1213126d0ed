"""The spatial cantilever of the benchmark's spatial group in Exudyn: its implicit step.

The model
---------
flexure's `spatial.spatial_cantilever(n)`: a clamped steel strip of 0.2 m along x (E 210 GPa,
nu 0.3, rho 7850 kg/m^3; 1 mm along y, 10 mm along z, as flexure's BEAM reads `width` 0.01
and `height` 0.001 with y_axis = y), a 1 N tip force in -z from rest, 6 n DOFs. Exudyn:
n ObjectBeamGeometricallyExact elements (two-node, shear-deformable, Lie-group strains) on
NodeRigidBodyEP nodes, the clamped node's seven coordinates held but its Euler parameter p0
(the nodes' normalisation fixes it), the section EA, 5/6 GA twice, G It (It = a b^3 / 3
(1 - 0.63 b / a)), E Iy, E Iz and the rotary inertia rho (Iy + Iz, Iy, Iz).

Checks (Exudyn 1.13.6, n = 16): the static tip deflection 1.52529e-4 m against flexure's
1.52381e-4 m (0.1 %: the beam's shear, which flexure's BEAM has not); the lowest natural
frequencies 20.90, 132.1, 208.6, 376.7 Hz against flexure's 20.87, 130.8, 208.8, 366.5 Hz
(Exudyn's linear interpolation converges from above). The tip's motion over 5 ms agrees
with flexure's *undamped* strip within 4e-3 of its largest deflection; it is not the
benchmark's damped strip: this element leaves the section's dampingMatrix out (a run with
beta times the stiffness there gives the same bits as one without), so Exudyn's strip is
undamped.

The step
--------
Generalized-alpha (spectral radius 0.8) at a fixed step, Newton to a relative 1e-7 (at 1e-8
Newton fails below h = 1e-4 on round-off and Exudyn halves its steps), the sparse LU
(EigenSparse), no output. One step is `run`'s CPU time over its steps. Its time error at
h = 1e-4 is 2 % of the largest deflection (against its own h = 2e-6 run): Exudyn's step
buys far less accuracy than flexure's (5e-7 at rtol 1e-6), so the row compares the cost of
a step, as the issue's target does; `cantilever_precision` compares the two at equal error
(`tip_history`: the tip at sample times, a sensor's).
"""

import time
import warnings

import exudyn as exu
import exudyn.itemInterface as ei
import numpy as np

LENGTH, E, NU, RHO = 0.2, 2.1e11, 0.3, 7850.0  # m, Pa, 1, kg/m^3
ALONG_Y, ALONG_Z = 0.001, 0.01  # m: the strip's section
TIP_FORCE = -1.0  # N, in z


def build(n):
    """(system container, main system, the tip node) of the strip of n beams."""
    g = E / (2 * (1 + NU))
    area = ALONG_Y * ALONG_Z
    iy, iz = ALONG_Y * ALONG_Z**3 / 12, ALONG_Z * ALONG_Y**3 / 12  # m^4: about y, about z
    a, b = max(ALONG_Y, ALONG_Z), min(ALONG_Y, ALONG_Z)
    torsion = a * b**3 / 3 * (1 - 0.63 * b / a)
    section = exu.BeamSection()
    section.stiffnessMatrix = np.diag([E * area, 5 / 6 * g * area, 5 / 6 * g * area,
                                       g * torsion, E * iy, E * iz])
    section.massPerLength = RHO * area
    section.inertia = RHO * np.diag([iy + iz, iy, iz])
    container = exu.SystemContainer()
    mbs = container.AddSystem()
    rest = [1.0, 0.0, 0.0, 0.0]  # the Euler parameters of no rotation
    previous = first = mbs.AddNode(ei.NodeRigidBodyEP(referenceCoordinates=[0, 0, 0] + rest))
    for k in range(1, n + 1):
        node = mbs.AddNode(ei.NodeRigidBodyEP(
            referenceCoordinates=[LENGTH * k / n, 0, 0] + rest))
        with warnings.catch_warnings():  # `physicsLength` is the name older versions know
            warnings.simplefilter("ignore", DeprecationWarning)
            mbs.AddObject(ei.ObjectBeamGeometricallyExact(
                nodeNumbers=[previous, node], physicsLength=LENGTH / n, sectionData=section))
        previous = node
    tip = mbs.AddMarker(ei.MarkerNodeRigid(nodeNumber=previous))
    mbs.AddLoad(ei.Force(markerNumber=tip, loadVector=[0, 0, TIP_FORCE]))
    ground = mbs.AddNode(ei.NodePointGround(referenceCoordinates=[0, 0, 0]))
    held = mbs.AddMarker(ei.MarkerNodeCoordinate(nodeNumber=ground, coordinate=0))
    for i in (0, 1, 2, 4, 5, 6):  # x, y, z and p1 .. p3; p0 by the normalisation
        marker = mbs.AddMarker(ei.MarkerNodeCoordinate(nodeNumber=first, coordinate=i))
        mbs.AddObject(ei.CoordinateConstraint(markerNumbers=[held, marker]))
    mbs.Assemble()
    return container, mbs, previous


def run(n, *, h=1e-4, t_end=5e-3):
    """(CPU s per step, the tip's z (m) at t_end) of `n` beams stepped at h (s) to t_end."""
    container, mbs, tip = build(n)
    steps = int(round(t_end / h))
    settings = _settings(h, t_end)
    start = time.process_time()
    exu.SolveDynamic(mbs, settings, showHints=False)
    cpu = time.process_time() - start
    return cpu / steps, mbs.GetNodeOutput(tip, exu.OutputVariableType.Position)[2]


def _settings(h, t_end, newton_tolerance=1e-7):
    """Exudyn's settings of the module's docstring: fixed step h (s) to t_end (s), Newton to
    the relative `newton_tolerance`."""
    settings = exu.SimulationSettings()
    steps = int(round(t_end / h))
    settings.timeIntegration.numberOfSteps = steps
    settings.timeIntegration.endTime = t_end
    settings.timeIntegration.verboseMode = 0
    settings.timeIntegration.generalizedAlpha.spectralRadius = 0.8
    settings.timeIntegration.newton.relativeTolerance = newton_tolerance
    with warnings.catch_warnings():  # the settings' older names, which 1.13 still reads
        warnings.simplefilter("ignore", DeprecationWarning)
        settings.solutionSettings.writeSolutionToFile = False
        settings.linearSolverType = exu.LinearSolverType.EigenSparse
        settings.displayStatistics = False
        settings.displayComputationTime = False
    return settings


def tip_history(n, *, h, samples, newton_tolerance=1e-6):
    """(CPU s of the run, the tip's z (m) at `samples`) of `n` beams stepped at h (s) to the
    last sample, each sample time a whole number of steps; the z stored by a sensor at each
    sample (its cost included: a user reads the answer). Newton's relative tolerance 1e-6:
    at 1e-7 the 64-beam strip's Newton fails on round-off from h = 5e-5 s down; 1e-6 and
    1e-5 give the same tip within 1e-8 of its deflection at h = 1e-4 ... 1e-5."""
    steps_at = np.rint(np.asarray(samples) / h).astype(int)
    if np.any(np.abs(steps_at * h - samples) > 1e-9 * samples[-1]):
        raise ValueError(f"h = {h:g} s does not divide the sample times")
    container, mbs, tip = build(n)
    sensor = mbs.AddSensor(ei.SensorNode(nodeNumber=tip, storeInternal=True,
                                         outputVariableType=exu.OutputVariableType.Position))
    mbs.Assemble()
    settings = _settings(h, float(samples[-1]), newton_tolerance)
    with warnings.catch_warnings():  # the older name, which 1.13 still reads
        warnings.simplefilter("ignore", DeprecationWarning)
        settings.solutionSettings.sensorsWritePeriod = float(samples[1] - samples[0])
    start = time.process_time()
    exu.SolveDynamic(mbs, settings, showHints=False)
    cpu = time.process_time() - start
    stored = mbs.GetSensorStoredData(sensor)  # rows [t, x, y, z], from t = 0
    z = np.interp(samples, stored[:, 0], stored[:, 3])
    return cpu, z
