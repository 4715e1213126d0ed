"""Model reduction: which released deformations a model can prescribe zero while its lowest
modes stay where they are.

A released (or DOF) deformation adds a DOF. Stiff ones, a leaf spring's elongation or its
in-plane bending, carry almost none of the energy of the low modes and only add high modes
(the parasitic modes a controller must see, but not every one of them) and integration
cost. SPACAR users freeze them by hand; `propose_reduction` does it by measurement:

1. The lowest `keep` modes of the scene's model at its static equilibrium. In each mode phi
   the deformations move by de = De DF phi; deformation d carries the strain energy
   u_d = de_d (S de)_d (S the deformation stiffness, block-diagonal per element), and its
   share of the mode's energy is |u_d| / sum |u_d|.
2. A scene element's deformation (all its segments together, since the scene's `released`
   and `dof` lists apply to every segment) gets the largest share it has in any kept mode.
3. Deformations are frozen (prescribed zero: removed from `released` and `dof`) in order of
   increasing share (equal shares, within `ties.TIE_RTOL`, in the scene's order), as many
   as keep the `keep` lowest frequencies within `tolerance` (%, relative to each): the
   largest count that does, by bisection over the count (each trial
   builds the reduced scene and computes its modes; for a model at rest without load, the
   trials project the full model's linearisation instead, exact to round-off, and the
   chosen reduced scene is built once: `projected_frequencies`). A deformation whose freezing would
   over-constrain the model together with those before it (a release that removes an
   over-constraint, such as a leaf's local cut, or the second leaf of a parallel pair) is
   skipped: `freezing.freezable` tests the rank of the constraint rows incrementally, so
   that every trial builds.

`freeze` (`flexure reduce --freeze e1`) prescribes the named deformations zero on every
element before anything else, whatever the tolerance (the chapter's elongation-frozen model);
the reduction goes on from there.

The reduced scene keeps the scene's DOF lists where they still count right (a frozen DOF
deformation is simply no DOF any more); where they do not (a frozen released deformation
removes a freedom some DOF stood for), it lists none and flexure chooses its DOFs
(`constraints.choose_dofs`), the scene's DOF deformations becoming released ones. A trial
that builds no valid model counts as too much freezing.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np

from ..errors import FlexureError
from ..mechanics import assembly
from ..mechanics.freezing import freezable
from ..numerics.blas import blas_threads
from ..numerics.ties import ordered
from ..scene.building import build_model
from ..scene.meshing import segment_names
from .linearization import linearize
from .modal import natural_frequencies
from .statics import static_equilibrium

__all__ = ["Reduction", "energy_shares", "propose_reduction"]


@dataclass
class Reduction:
    """What `propose_reduction` found; frequencies in Hz, shares as fractions."""

    keep: int
    tolerance: float  # %
    frozen: list  # [(scene element, deformation)] prescribed zero in the reduced scene
    scene: dict  # the reduced scene
    full_hz: np.ndarray  # the lowest `keep` frequencies of the scene
    reduced_hz: np.ndarray  # and of the reduced scene
    ndof_full: int
    ndof_reduced: int
    shares: dict = field(default_factory=dict)  # (element, deformation) -> energy share
    dofs_chosen: bool = False  # the reduced scene lists no DOFs (flexure chooses them)
    forced: list = field(default_factory=list)  # the pairs `freeze` asked for (and kept valid)
    forced_hz: np.ndarray | None = None  # the frequencies with those alone frozen
    ndof_forced: int | None = None

    @property
    def change_percent(self):
        """The largest relative change of the kept frequencies (%)."""
        return float(np.max(np.abs(self.reduced_hz / self.full_hz - 1.0)) * 100.0)


def lowest_frequencies(model, keep):
    """The lowest `keep` natural frequencies (Hz) at the static equilibrium, and the modes."""
    solution = static_equilibrium(model)
    lin = linearize(model, solution)
    modes = natural_frequencies(model, keep, linear_model=lin)
    return modes, solution


def energy_shares(model, data, keep):
    """{(scene element, deformation): the largest share of the strain energy of any of the
    lowest `keep` modes that it carries} for the released and DOF deformations of `model`,
    built from scene `data` (whose segmented elements' segments are summed)."""
    modes, solution = lowest_frequencies(model, keep)
    De = solution.config.De  # de/dx at the equilibrium (the kinematics' first order)
    S, _ = assembly.stiffness_and_damping(model)
    # the keep shapes on the coordinates first: (De DF) would be an (NE, NDOF) product
    moved = De @ (modes.linear_model.DF @ modes.shapes)  # (NE, keep)
    energy = np.abs(moved * (S @ moved))
    total = energy.sum(axis=0)
    share = energy / np.where(total > 0.0, total, 1.0)
    return {key: float(share[rows].sum(axis=0).max())
            for key, rows in deformation_rows(model, data).items()}, modes


def propose_reduction(data: dict, keep: int, tolerance: float = 1.0, *, freeze=(),
                      source: str = "<dict>", progress=None) -> Reduction:
    """The reduction of scene `data` (a dict) that freezes the most released deformations
    while its lowest `keep` frequencies move by at most `tolerance` percent; `progress` is
    called with the fraction of the trials done. `freeze` names deformations ("e1": every
    elongation) prescribed zero on every element first, whatever the tolerance says (but not
    where that over-constrains the model), as the chapter's elongation-frozen model; the
    reduction then goes on from there. Raises FlexureError when the scene has fewer than
    `keep` DOFs."""
    model = build_model(data, source=source)
    if keep > model.ndof:
        raise FlexureError(f"{source}: --keep {keep}: the model has only {model.ndof} DOFs")
    shares, modes = energy_shares(model, data, keep)
    full = modes.frequencies_hz
    # a name no element has is a mistake; one every element prescribes already is not (the
    # elongations of a model whose scene froze them): nothing more to freeze
    existing = sorted({name.rsplit(".", 1)[1] for name in model.deformation_names})
    unknown = [name for name in freeze if name not in existing]
    if unknown:
        raise FlexureError(f"{source}: --freeze {','.join(unknown)}: no element of the model "
                           f"has {'it' if len(unknown) == 1 else 'them'} (its deformations: "
                           f"{', '.join(existing)})")
    # Freezing a deformation adds a constraint; some sets of them together over-constrain
    # (both leaves of a parallel pair frozen in torsion). Keep, in the order of freezing, only
    # what keeps the constraints independent, so that every prefix of `order` builds.
    # in the scene's order (element, then deformation); the rest by their share, smallest
    # first, equal shares (`ties.ordered`: two symmetric leaves) staying in the scene's order
    rank = {name: k for k, name in enumerate(data.get("elements", {}))}
    in_scene = sorted(shares, key=lambda key: (rank.get(key[0], len(rank)), key))
    forced = [key for key in in_scene if key[1] in set(freeze)]
    rest = [key for key in in_scene if key not in set(forced)]
    rest = [rest[k] for k in ordered([shares[key] for key in rest])]
    candidates = forced + rest
    rows = deformation_rows(model, data)
    taken = freezable(model, [rows[key] for key in candidates])
    order = [candidates[k] for k in taken]
    forced = [key for key in order if key in set(forced)]

    projected = projected_frequencies(model, modes.linear_model, rows, order, keep)

    def trial(count, *, build=False):
        """(reduced scene, its frequencies, whether the DOFs were chosen, NDOF, frozen), or
        None when the first `count` of `order` frozen give no valid model. Without `build`,
        where the model is at rest (`projected_frequencies`), the frequencies of the full
        model's linearisation restricted to the motions that keep them zero (the scene and
        the rest unset: only the bisection's verdict)."""
        chosen_set = order[:count]
        if projected is not None and not build:
            found = projected(count)
            return None if found is None else (None, found, None, None, chosen_set)
        scene, chosen = frozen_scene(data, chosen_set)
        try:
            reduced_model = build_model(scene, source=f"{source} (reduced)")
            found, _ = lowest_frequencies(reduced_model, keep)
        except FlexureError:
            return None
        if found.frequencies_hz.size < keep:
            return None
        return scene, found.frequencies_hz, chosen, reduced_model.ndof, chosen_set

    def within(result):
        return result is not None and np.all(
            np.abs(result[1] / full - 1.0) * 100.0 <= tolerance)

    best = (copy.deepcopy(data), full, False, model.ndof, [])
    forced_hz = ndof_forced = None
    if forced:
        best = trial(len(forced), build=True)
        if best is None:
            raise FlexureError(f"{source}: --freeze {','.join(freeze)}: the model with those "
                               "deformations frozen has no valid modes")
        forced_hz, ndof_forced = best[1], best[3]
    trials = 1 + max(1, len(order)).bit_length()  # the bisection's most
    done = 0

    def report():
        nonlocal done
        done += 1
        if progress is not None:
            progress(min(done / trials, 1.0))

    def bisection(start, build):
        """The largest count of `order` frozen within the tolerance, by bisection over the
        count from `start` (the forced ones frozen, passing)."""
        low, high, best = len(forced), len(order), start  # low passes, high untested
        attempt = trial(high, build=build)
        report()
        if within(attempt):
            low, best = high, attempt
        while high - low > 1:
            middle = (low + high) // 2
            attempt = trial(middle, build=build)
            report()
            if within(attempt):
                low, best = middle, attempt
            else:
                high = middle
        return best

    start = best
    best = bisection(start, build=projected is None)
    if best[0] is None:  # a projected verdict: the reduced scene itself, built
        built = trial(len(best[4]), build=True)
        # the built model keeps the tolerance as its projection said (to round-off); if it
        # ever did not, the built trials decide, as they did before the projection
        best = built if within(built) else bisection(start, build=True)
    scene, reduced_hz, chosen, ndof, frozen = best
    return Reduction(keep=keep, tolerance=tolerance, frozen=frozen, scene=scene,
                     full_hz=full, reduced_hz=reduced_hz, ndof_full=model.ndof,
                     ndof_reduced=ndof, shares=shares, dofs_chosen=chosen, forced=forced,
                     forced_hz=forced_hz, ndof_forced=ndof_forced)


def projected_frequencies(model, lin, rows, order, keep):
    """A function giving the lowest `keep` frequencies (Hz) of `model` with the first `count`
    deformations of `order` (keys of `rows`, whose values are index arrays) frozen, from its
    linearisation `lin`, or None where that is not exact.

    Exact for a model at rest in its initial configuration: no stress anywhere (G0 = 0: round-
    off, at most 1e-12 of K0's largest entry; 1e-16 on manipulator_e1) and every candidate
    deformation zero there (within 1e-12 of the coordinates' size), so that the reduced model
    rests in the same configuration. Its DOFs' motions are then the full model's that keep the
    frozen deformations zero, dq = N z with N an orthonormal basis of the null space of C =
    De_f DF (k, NDOF); its M0 and K0 are N^T M0 N and N^T K0 N (every term of the frozen
    deformations carries De_f DF N = 0), whatever DOFs the reduced scene gets.

    The trials freeze prefixes of one order, so one factorisation serves them all: with the
    rows of all of `order` stacked, C^T = Q R (Householder, complete Q), the first k columns
    of Q span the first k rows (`freezable` has made them independent: R's leading k x k
    block is regular) and N = Q[:, k:] for every prefix of k rows. K0 and M0 are transformed
    once, Q^T K0 Q and Q^T M0 Q (0.09 s on manipulator_e1), and a trial's matrices are their
    trailing blocks: a trial costs its eigenvalues alone (0.02 s, where projecting on each
    trial's own null space cost 0.09 s). The frequencies agree with the built model's to
    round-off (tests/test_reduction.py; the soft modes' round-off is amplified by the stiff
    released deformations in K0: two orthonormal bases of one null space, Householder's and
    the SVD's, give manipulator_e1's lowest seven frequencies 1e-7 apart), and the reduced
    scene is built once, for its own figures.
    """
    import scipy.linalg

    config = lin.solution.config
    candidates = np.concatenate([np.asarray(r, dtype=np.int64) for r in rows.values()]
                                or [np.zeros(0, dtype=np.int64)])
    scale = max(float(np.abs(config.x).max(initial=0.0)), 1e-300)
    stiffness = float(np.abs(lin.K0).max(initial=0.0))
    if (model.kinematic_inputs or np.abs(lin.G0).max(initial=0.0) > 1e-12 * stiffness
            or np.any(np.abs(config.e[candidates]) > 1e-12 * scale)):
        return None
    ndof = lin.DF.shape[1]
    sizes = np.cumsum([0] + [len(rows[key]) for key in order])  # rows frozen by a count
    stacked = np.concatenate([np.asarray(rows[key], dtype=np.int64) for key in order]
                             or [np.zeros(0, dtype=np.int64)])
    with blas_threads():  # as every analysis: one BLAS thread (`numerics.blas`)
        q, _ = np.linalg.qr((config.De[stacked] @ lin.DF).T, mode="complete")
        K, M = q.T @ lin.K @ q, q.T @ lin.M0 @ q

    @blas_threads()
    def frequencies(count):
        frozen = int(sizes[count])
        if ndof - frozen < keep:
            return None
        try:
            values = scipy.linalg.eigh(K[frozen:, frozen:], M[frozen:, frozen:],
                                       eigvals_only=True, subset_by_index=[0, keep - 1])
        except np.linalg.LinAlgError:
            return None
        return np.sign(values) * np.sqrt(np.abs(values)) / (2.0 * np.pi)

    return frequencies


def frozen_scene(data, frozen):
    """Scene `data` with the (element, deformation) pairs of `frozen` prescribed zero, and
    whether its DOF lists had to go (see the module docstring)."""
    scene = copy.deepcopy(data)
    released_frozen = False
    for element, deformation in frozen:
        table = scene["elements"][element]
        for status in ("released", "dof"):
            names = table.get(status)
            if isinstance(names, str):
                names = [names]
            if names and deformation in names:
                table[status] = [n for n in names if n != deformation]
                released_frozen |= status == "released"
    if not released_frozen:
        return scene, False
    for node in scene.get("nodes", {}).values():
        node.pop("dof", None)
    for table in scene["elements"].values():
        listed = table.pop("dof", [])
        if listed:
            released = table.get("released", [])
            released = [released] if isinstance(released, str) else list(released)
            table["released"] = released + [d for d in listed if d not in released]
    return scene, True


def deformation_rows(model, data):
    """{(scene element, deformation): the model's deformation indices of it (one per
    segment)} for the released and DOF deformations of `model`."""
    owner = _scene_elements(data)
    rows = {}
    for d in model.stressed_deformations:
        element, deformation = model.deformation_names[d].rsplit(".", 1)
        rows.setdefault((owner.get(element, element), deformation), []).append(int(d))
    return rows


def _scene_elements(data):
    """{model element name: scene element name} for the segments of segmented elements."""
    owner = {}
    for name, table in data.get("elements", {}).items():
        count = table.get("segments", 1) if isinstance(table, dict) else 1
        if isinstance(count, int) and count > 1:
            owner.update({segment: name for segment in segment_names(name, count)})
    return owner
