"""The planar leaf-spring stage in Exudyn: the model the peer side of the benchmark runs
(`peer_exudyn`), built by `build` from the sections of a scene (`Stage`).

The model
---------
The stage of examples/scenes/stage_planar_{1,3}dof.toml, its sections read from the scene:
a bar from (0, 0.1) to (0.1, 0.1) m on two vertical leaf springs of 0.1 m clamped at (0, 0)
and (0.1, 0). The input F (N) acts in x on the bar's left end (flexure's node 3); the output
is the x position (m) of that point.

- Each leaf spring: `n` ObjectANCFCable2D elements (cubic planar ANCF cable, nodes
  NodePoint2DSlope1 with position and slope), EA = E w h = 1.89e6 N, EI = E w h^3 / 12 =
  0.039375 N m^2, rho A = rho w h = 0.07065 kg/m, consistent mass. The clamp fixes x, y and
  the x slope of the bottom node (the y slope, which carries the axial strain, stays free).
- The bar: a rigid body (NodeRigidBody2D, ObjectRigidBody2D) at its centre (0.05, 0.1) m
  with the mass 0.206 kg (rho A = 2.06 kg/m over 0.1 m) and the rotational inertia of a
  uniform bar about its centre, m L^2 / 12 = 1.717e-4 kg m^2: what flexure's rigid PLBEAM
  with its consistent mass carries. A rigid body rather than a stiff cable: a cable's slope
  nodes cannot be shared with the vertical leaves at a right angle, and a stiff element
  would only add a stiff mode.
- Each leaf top is welded to its bar end by an ObjectJointGeneric (x, y and the rotation
  about z) between MarkerBodyRigid markers on the cable end and on the bar.
- Damping: the cable's bendingDamping and axialDamping are the scene's EdI (N m^2 s) and EdA
  (N s), viscous in the rates of curvature and axial strain: the same stiffness-proportional
  deformation-rate damping as the scene's PLBEAMs (Ed / E times the stiffness of the
  deformations). The rigid bar is undamped on both sides.
- Solver: generalized-alpha (Exudyn's default implicit solver; spectral radius 0.9), fixed
  step h, Exudyn's modified Newton (Jacobian kept over steps), no solution file; the
  position is stored every step by a sensor.

Checks (Exudyn 1.13.6). First natural frequency from ComputeODE2Eigenvalues (joints
projected out), flexure 10.645 Hz; static stiffness F / x at F = 1 N (SolveStatic), the
linear 24 EI / l^3 = 945 N/m:

    n    f1 (Hz)    f2, f3 (Hz)           F / x at 1 N (N/m)
    1    10.64472   2131.6, 3598.0        1000.6  (945.17 with reduced_integration)
    2    10.64462    270.1,  271.7         959.9  (959.7)
    4    10.64461    266.2,  267.7         945.56
    8    10.64461    265.9,  267.4         945.09
    16   10.64461    265.8,  267.4         945.08

For n = 1 the modes above are flexure's 3-DOF ones (vertical 2129 Hz, rotation 3585 Hz);
from n = 2 on the leaves' own bending modes (266 Hz, as a clamped-clamped leaf) appear,
which flexure's one PLBEAM per spring does not have (its 4-element model would).

What is not flexure's model
---------------------------
- Membrane locking: with its full Gauss integration one cable per spring is 6 % too stiff
  at 1 mm of deflection (the cubic element cannot bend without stretching), 1.6 % with two;
  its first frequency, taken at rest, does not show it. `reduced_integration=True`
  (useReducedOrderIntegration) cures n = 1, not n = 2; n >= 4 is converged. flexure's
  PLBEAM carries no such error.
- The cable always has its axial compliance EA: stage_planar_3dof (elongations released).
  stage_planar_1dof has inextensible leaves, so the closed loop runs on the 3-DOF
  mechanics (its extra modes, at 2.1 and 3.6 kHz, are barely driven by an x force).
- Geometric nonlinearity: at 1 N (about 1 mm) the converged cables give 945.08 N/m, flexure
  945.000 N/m on stage_planar_1dof and 944.976 N/m on stage_planar_3dof (its static
  equilibrium): a 1e-4 difference of the two beam theories at a deflection of l / 100.
  This model difference, not the integrator (more steps per sample do not lower it), sets
  the closed-loop error: a few nm, against 4e-11 m for flexure on its own model.
- The damping acts on the axial strain and curvature rates at the cable's Gauss points,
  flexure's on the rates of the element's generalised deformations (e1, e2, e3); both are
  Ed / E times the corresponding stiffness, so they agree as far as the stiffnesses do.
- Integration: a fixed step with no error control (flexure's CVODE controls its error);
  generalized-alpha at spectral radius 0.9 damps the modes above ~1 / h a little.
- In the loop the load u_k, set in the PreStepUserFunction, is the load of the step's
  equilibrium at its end (generalized-alpha solves the equations at t_(k+1)); the previous
  step's load reaches it through the algorithmic accelerations. flexure holds u_k exactly
  over [t_k, t_(k+1)); the difference is of the integrator's O(h^2).
"""

import tomllib
from dataclasses import dataclass
from pathlib import Path

import exudyn as exu
import exudyn.itemInterface as ei
import numpy as np

SCENES = Path(__file__).resolve().parents[1] / "scenes"  # examples/scenes
LEAF_LENGTH = 0.1  # m, the leaf springs and the bar
BAR_LENGTH = 0.1


@dataclass(frozen=True)
class Stage:
    """The sections of the stage (SI units), as in the scene file.

    Parameters
    ----------
    E : float
        Young's modulus of the leaves (Pa).
    rho : float
        Density of the leaves (kg/m^3).
    width, height : float
        Out-of-plane width and bending thickness of a leaf (m).
    EdA, EdI : float
        Axial (N s) and bending (N m^2 s) damping coefficients of a leaf.
    bar_rho_A : float
        Mass per length of the bar (kg/m).
    """

    E: float
    rho: float
    width: float
    height: float
    EdA: float
    EdI: float
    bar_rho_A: float

    @classmethod
    def from_scene(cls, scene="stage_planar_3dof"):
        """The sections of a scene: a name in examples/scenes or a scene file."""
        path = Path(scene)
        path = path if path.suffix == ".toml" else SCENES / f"{scene}.toml"
        with open(path, "rb") as handle:
            data = tomllib.load(handle)
        leaf, bar = data["sections"]["leaf"], data["sections"]["bar"]
        return cls(E=leaf["E"], rho=leaf["rho"], width=leaf["width"], height=leaf["height"],
                   EdA=leaf["EdA"], EdI=leaf["EdI"], bar_rho_A=bar["rho_A"])

    @property
    def EA(self):
        """Axial stiffness of a leaf (N)."""
        return self.E * self.width * self.height

    @property
    def EI(self):
        """Bending stiffness of a leaf (N m^2)."""
        return self.E * self.width * self.height**3 / 12

    @property
    def rho_A(self):
        """Mass per length of a leaf (kg/m)."""
        return self.rho * self.width * self.height

    @property
    def bar_mass(self):
        """Mass of the bar (kg)."""
        return self.bar_rho_A * BAR_LENGTH

    @property
    def bar_inertia(self):
        """Rotational inertia of the bar about its centre, a uniform bar (kg m^2)."""
        return self.bar_mass * BAR_LENGTH**2 / 12

    @property
    def stiffness(self):
        """Linear stiffness in x of the two clamped-guided leaves, 24 EI / l^3 (N/m)."""
        return 24 * self.EI / LEAF_LENGTH**3


@dataclass
class StageModel:
    """An assembled Exudyn model of the stage and the handles a run needs."""

    SC: object  # the SystemContainer, kept alive with its system
    mbs: object
    output_node: int  # the leaf top at the bar's left end (flexure's node 3)
    load: int  # the force in x on that node
    sensor: int  # the position of that node, stored every step


def build(n=1, stage=None, *, force=0.0, reduced_integration=False):
    """Build and assemble the stage with `n` ANCF cable elements per leaf spring.

    Parameters
    ----------
    n : int
        Elements per leaf spring.
    stage : Stage, optional
        The sections (default: those of stage_planar_3dof).
    force : float
        The constant force (N) in x on the bar's left end.
    reduced_integration : bool
        The cable's useReducedOrderIntegration (Gauss order 7 for the axial and 3 for the
        bending virtual work instead of 9 and 5): removes the membrane locking of n = 1.

    Returns
    -------
    StageModel
    """
    stage = stage or Stage.from_scene()
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddMarker(ei.MarkerNodeCoordinate(nodeNumber=mbs.AddNode(
        ei.NodePointGround()), coordinate=0))
    bar = mbs.AddObject(ei.ObjectRigidBody2D(
        mass=stage.bar_mass, inertia=stage.bar_inertia, nodeNumber=mbs.AddNode(
            ei.NodeRigidBody2D(referenceCoordinates=[BAR_LENGTH / 2, LEAF_LENGTH, 0.0]))))
    le = LEAF_LENGTH / n
    tops = []
    for x0 in (0.0, BAR_LENGTH):
        nodes = [mbs.AddNode(ei.NodePoint2DSlope1(referenceCoordinates=[x0, i * le, 0.0, 1.0]))
                 for i in range(n + 1)]
        cables = [mbs.AddObject(ei.ObjectANCFCable2D(
            length=le, massPerLength=stage.rho_A, bendingStiffness=stage.EI,
            axialStiffness=stage.EA, bendingDamping=stage.EdI, axialDamping=stage.EdA,
            useReducedOrderIntegration=int(reduced_integration),
            nodeNumbers=[nodes[i], nodes[i + 1]])) for i in range(n)]
        for coordinate in (0, 1, 2):  # the clamp: x, y and the x slope of the bottom node
            marker = mbs.AddMarker(ei.MarkerNodeCoordinate(nodeNumber=nodes[0],
                                                           coordinate=coordinate))
            mbs.AddObject(ei.CoordinateConstraint(markerNumbers=[ground, marker]))
        # the weld of the leaf top to the bar end: x, y and the rotation; the marker frame
        # on the bar is turned by 90 degrees to the cable end's (its x axis along the leaf)
        weld = [mbs.AddMarker(ei.MarkerBodyRigid(bodyNumber=bar, localHT=exu.HT(
                    rotation=_rotation_z(np.pi / 2), translation=[x0 - BAR_LENGTH / 2, 0, 0]))),
                mbs.AddMarker(ei.MarkerBodyRigid(bodyNumber=cables[-1],
                                                 localPosition=[le, 0, 0]))]
        mbs.AddObject(ei.ObjectJointGeneric(markerNumbers=weld,
                                            constrainedAxes=[1, 1, 0, 0, 0, 1]))
        tops.append(nodes[-1])
    load = mbs.AddLoad(ei.LoadForceVector(
        markerNumber=mbs.AddMarker(ei.MarkerNodePosition(nodeNumber=tops[0])),
        loadVector=[force, 0.0, 0.0]))
    sensor = mbs.AddSensor(ei.SensorNode(nodeNumber=tops[0], storeInternal=True,
                                         outputVariableType=exu.OutputVariableType.Position))
    mbs.Assemble()
    return StageModel(SC, mbs, tops[0], load, sensor)


def _rotation_z(angle):
    c, s = np.cos(angle), np.sin(angle)
    return [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]


def simulation_settings(h, t_end, *, n=1, newton_tolerance=1e-8, newton_absolute=None):
    """Generalized-alpha at the fixed step `h` (s) up to `t_end` (s), no output files.

    `newton_tolerance` is Newton's relative tolerance on the residual (Exudyn's default
    1e-8); `newton_absolute` its absolute tolerance on the residual (N), by default
    1e-8 n^2 for `n` elements per spring: Exudyn's default 1e-10 lies below the round-off of
    the residual, which grows with the axial stiffness EA n / l of the elements (measured
    at zero load: 2e-10 N for n = 1, 3e-9 N for n = 4, 4e-8 N for n = 16), so that a step
    from zero load never converges.
    """
    if newton_absolute is None:
        newton_absolute = 1e-8 * n**2
    settings = exu.SimulationSettings()
    ti = settings.timeIntegration
    ti.numberOfSteps = int(round(t_end / h))
    ti.endTime = ti.numberOfSteps * h
    ti.adaptiveStep = False
    ti.verboseMode = 0
    ti.newton.relativeTolerance = newton_tolerance
    ti.newton.absoluteTolerance = newton_absolute
    settings.solution.file.write = False
    settings.solution.sensors.writePeriod = 0.5 * h  # every step
    settings.show.computationTime = False
    settings.show.statistics = False
    return settings


def natural_frequencies(n=1, count=3, **options):
    """The lowest natural frequencies (Hz) of the undamped stage at rest.

    Parameters
    ----------
    n : int
        Elements per leaf spring.
    count : int
        How many frequencies.
    **options
        stage, reduced_integration: passed to `build`.

    Returns
    -------
    array (count,)
        Hz; from ComputeODE2Eigenvalues, the joints projected out by its SVD.
    """
    model = build(n, **options)
    values, _ = model.mbs.ComputeODE2Eigenvalues(convert2Frequencies=True)
    values = np.sort(np.asarray(values))
    return values[values > 1e-3][:count]
