"""The fields of the engine's record slots, described once: slot `dims`, a row of slot
`groups`, slot `counters` and slot `settings` (`layout`, whose docstring says what the roles
mean and how the index constants come from these tables)."""

from dataclasses import dataclass

CONFIG, STATE, SCRATCH, MIXED = "config", "state", "scratch", "config and state"


@dataclass(frozen=True)
class Field:
    """One entry of a record slot (`dims`, a row of `groups`, `counters`, `settings`):
    `name` (its key when packed), `constant` (its index constant in `data`), `role`,
    `meaning`."""

    name: str
    constant: str
    role: str
    meaning: str


# fmt: off
# -- the fields of slot dims ---------------------------------------------------------------
DIMS_FIELDS = tuple(Field(*row) for row in (
    ("nx", "NX", CONFIG, "coordinates"),
    ("ne", "NE", CONFIG, "deformations"),
    ("ndof", "NDOF", CONFIG, "DOFs"),
    ("nfree", "NFREE", CONFIG, "free coordinates (the slaves' out)"),
    ("nrigid", "NRIGID", CONFIG, "rigid rows of g (the multipliers of the augmented system)"),
    ("nxdof", "NXDOF", CONFIG, "DOF coordinates"),
    ("nedof", "NEDOF", CONFIG, "DOF deformations"),
    ("nin", "NIN", CONFIG, "inputs"),
    ("ns", "NS", CONFIG, "stressed deformations"),
    ("ngroups", "NGROUPS", CONFIG, "element groups (the model's and the node inertias')"),
    ("has_damping", "HAS_DAMPING", CONFIG, "1 when D has an entry"),
    ("max_m", "MAX_M", CONFIG, "the most coordinates of an element (z-coordinates included)"),
    ("max_k", "MAX_K", CONFIG, "the most deformations of an element"),
    ("max_p", "MAX_P", CONFIG, "the most inertia points of an element"),
    ("chord_iterations", "CHORD_ITERATIONS", CONFIG, "the kinematics' chord iterations"),
    ("max_newton", "MAX_NEWTON", CONFIG, "the kinematics' full Newton iterations"),
    ("warm", "WARM", STATE, "1: x holds a solution with J's factors (the next kinematics "
     "starts from it), 0: from x_start"),
    ("jacobian_reuse", "JACOBIAN_REUSE", STATE, "1: the next Jacobian call returns the kept "
     "one (`sundials`)"),
    ("engine", "ENGINE", STATE, "the address of the engine's table of entries "
     "(`engine.connect`)"),
    ("augmented", "AUGMENTED", CONFIG, "1: accelerations from the augmented system, 0: the "
     "reduced one"),
    ("reduced", "REDUCED", STATE, "1: the last evaluation formed DF and M_bar"),
    ("mass_current", "MASS_CURRENT", STATE, "1: M_bar and its LU are of the last "
     "configuration"),
    ("j_kl", "J_KL", CONFIG, "J's sub-diagonals in its banded order"),
    ("j_ku", "J_KU", CONFIG, "its super-diagonals"),
    ("a_kl", "A_KL", CONFIG, "the augmented system's sub-diagonals"),
    ("a_ku", "A_KU", CONFIG, "its super-diagonals"),
    ("j_sparse", "J_SPARSE", CONFIG, "1: J factored by the sparse LU"),
    ("a_sparse", "A_SPARSE", CONFIG, "1: the augmented system by the sparse LU"),
    ("j_factors", "J_FACTORS", STATE, "which of J's factors are current (NO_FACTORS, ...)"),
    ("nel", "NEL", CONFIG, "coil currents (states after [q - q_ref, qdot])"),
    ("nslaves", "NSLAVES", CONFIG, "slave nodes of the rigid clusters"),
    ("a_rigid", "A_RIGID", CONFIG, "where the touching elements' entries begin in the "
     "augmented map, or -1"),
    ("a_factors", "A_FACTORS", STATE, "which of the augmented system's factors are current"),
    ("a_kept", "A_KEPT", STATE, "which factors of the augmented system at some earlier state "
     "the storage holds for refinement (`refinement`: KEPT_NONE = 0, ...)"),
    ("nki", "NKI", CONFIG, "kinematic inputs (prescribed DOFs: `prescribed`)"),
    ("newton_sparse", "NEWTON_SPARSE", CONFIG, "1: the ESDIRK's Newton matrix in coordinate "
     "space, sparse (`newton`)"),
    ("static", "STATIC", CONFIG, "1: the reduced evaluation forms DF^T r and no M_bar or "
     "qddot (the statics' own packed model, `static_engine`)"),
    ("prediction_held", "PREDICTION_HELD", STATE, "1: the last warm kinematics' first-order "
     "prediction held (the next evaluates e with De at its prediction, in one pass)"),
    ("conv_pending", "CONV_PENDING", STATE, "1: slot conv holds J's right-hand side of the "
     "last evaluation's convective accelerations, not yet solved (`convective`)"),
    ("conv_wanted", "CONV_WANTED", STATE, "1: every evaluation forms slot conv at once (for "
     "the Python readers of slot conv; `convective`)"),
    ("points_current", "POINTS_CURRENT", STATE, "1: slot beam_points holds the BEAMs' "
     "inertia points at slots x and xdot (set by the element rates when moving, cleared by "
     "the kinematics)"),
    ("rotations_kept", "ROTATIONS_KEPT", STATE, "1: slot beam_points holds the BEAMs' "
     "rotations that the last deformations evaluation kept (`entries.ORDER_KEPT`), the "
     "node vectors and the section axes' Dp blocks, for their rates"),
))

# -- the fields of a row of slot groups (one row per element group) -------------------------
GROUP_FIELDS = tuple(Field(*row) for row in (
    ("count", "G_COUNT", CONFIG, "its elements n"),
    ("m", "G_M", CONFIG, "coordinates per element"),
    ("k", "G_K", CONFIG, "deformations per element"),
    ("p", "G_P", CONFIG, "inertia points per element (0: none)"),
    ("ref_width", "G_REF_WIDTH", CONFIG, "the width of its packed reference rows"),
    ("coord_offset", "G_COORD_OFFSET", CONFIG, "its first entry in coordinate_index"),
    ("def_offset", "G_DEF_OFFSET", CONFIG, "its first entry in deformation_index"),
    ("data_offset", "G_DATA_OFFSET", CONFIG, "its reference rows in group_data"),
    ("mass_offset", "G_MASS_OFFSET", CONFIG, "its Mp in group_data, or -1"),
    ("gravity_offset", "G_GRAVITY_OFFSET", CONFIG, "its points' gravity in group_data, or -1"),
    ("de_offset", "G_DE_OFFSET", CONFIG, "its first entry in De"),
    ("d2e_offset", "G_D2E_OFFSET", CONFIG, "its first entry in D2e"),
    ("deformations_entry", "G_DEFORMATIONS_ENTRY", CONFIG, "the address of its element "
     "module's compiled deformations"),
    ("inertia_entry", "G_INERTIA_ENTRY", CONFIG, "the address of its inertia kernel, or 0"),
    ("pattern_offset", "G_PATTERN_OFFSET", CONFIG, "its first entry in mass_pattern"),
    ("pattern_count", "G_PATTERN_COUNT", CONFIG, "its entries there"),
    ("element_offset", "G_ELEMENT_OFFSET", CONFIG, "its first element in rigid_element_of"),
    ("point_blocks", "G_POINT_BLOCKS", CONFIG, "1: the group's inertia points are the BEAM's, "
     "whose Dp is in blocks by construction (`beam_mass.blocks_by_construction`): r - M "
     "xddot takes the closed-form product without testing each element's Dp"),
    ("node_inertia", "G_NODE_INERTIA", CONFIG, "1: the group is the node inertias' with Mp "
     "diagonal (`node_inertia_product`: their points and products in closed form)"),
    ("points_offset", "G_POINTS_OFFSET", CONFIG, "its first entry in beam_points (a group "
     "with point_blocks), or -1"),
))

# -- slot counters and slot settings ----------------------------------------------------------
COUNTER_FIELDS = tuple(Field(*row) for row in (
    ("rhs", "RHS_COUNT", STATE, "right-hand sides the integrator asked for"),
    ("jacobians", "JACOBIAN_COUNT", STATE, "Jacobians the integrator asked for"),
    ("failed_status", "FAILED_STATUS", STATE, "the status of the last failed call, or 0"),
    ("sparse_pivoting", "SPARSE_PIVOTING", STATE, "sparse LUs that pivoted afresh because a "
     "kept pivot failed its test"),
    ("sparse_fallbacks", "SPARSE_FALLBACKS", STATE, "those that could not, and were banded"),
    ("evaluations", "EVALUATIONS", STATE, "evaluations of the accelerations"),
    ("refined_responses", "REFINED_RESPONSES", STATE, "input responses solved by refinement "
     "with kept factors (`refinement`)"),
    ("refinement_products", "REFINEMENT_PRODUCTS", STATE, "their products A d"),
    ("response_factors", "RESPONSE_FACTORS", STATE, "input responses that had A factored at "
     "a stage force's state (FACTOR_A)"),
))
SETTINGS_FIELDS = (
    Field("singular_ratio", "SINGULAR_RATIO", CONFIG, "the smallest ratio of J's LU pivots "
          "before a configuration counts as singular"),
)
# fmt: on
