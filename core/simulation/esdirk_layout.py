"""The compiled ESDIRK's workspace: the slots of its float memory, its int flags and
counters, the rows of its vector workspace, and its status codes. `esdirk_newton` (the
stages) and `esdirk_kernels` (the step and its control) index them; `Esdirk` and the
compiled sampled loop hold the arrays.
"""

from .esdirk_method import MAX_STAGES

# float64 memory slots
(M_T, M_H, M_RTOL, M_H_MAX, M_H_LU, M_ETA, M_EXPONENT, M_H_INPUT, M_SIZE) = range(9)
# memory[M_H_INPUT]: the step (s) the controller proposed after the last accepted first step
# after an input change (0: none yet); the next input change starts no larger (`restart`)
# int64 flags and counters; flags[I_FSAL]: F_1 to evaluate, F_1 current, F_1 = F_s of the inputs
# of the engine's last evaluation (counters[EVALUATIONS] = flags[I_EVALUATION]): add the response
FSAL_NONE, FSAL_CURRENT, FSAL_INPUTS = range(3)
(I_FSAL, I_JACOBIAN, I_FRESH, I_REFRESH, I_LU, I_STEPS, I_REJECTED, I_NEWTON_FAILURES,
 I_RHS, I_JACOBIANS, I_FACTORIZATIONS, I_REDUCED, I_ONE_STEP, I_MAX_STEPS, I_EVALUATION,
 I_HISTORY, I_EXTRA, I_MASS_FORM, I_RESPONSES, I_AFTER_INPUT, I_ETA_AGE, I_ETA_HOLD,
 I_LANDED, I_QUIET, I_BOUNDED_RESPONSE, I_SIZE) = range(26)
# flags[I_AFTER_INPUT] = 1 from an input change (`restart`) to the next accepted step;
# I_LANDED = 1 once a step lands on t_stop, and no restart since; I_QUIET = 1 once an advance
# started from a landing (a stretch with no input change: memory[M_H_INPUT] is stale)
# flags[I_ETA_AGE]: accepted steps since a stage last measured its contraction; the estimate
# grows at a step's first implicit stage once the age reaches flags[I_ETA_HOLD] (`_stage`)
# flags[I_BOUNDED_RESPONSE] = 1 (`Esdirk`'s default): the input response may stop refining at
# the step's weighted bound (`esdirk_kernels.response_weights`); 0 its fixed relative
# tolerance (for comparison)
# flags[I_RESPONSES]: the engine's input responses the first stage asked for (`advance`)
# flags[I_MASS_FORM] = 1 (`Esdirk`'s default): on the sparse Newton matrix the stages take
# their residual in mass form (`_mass_form_residual`); 0 the accelerations' (for comparison)
# flags[I_REDUCED]: the Newton matrix's factors are the full matrix's (0), its Schur
# complement's (1) or the engine's sparse ones (SPARSE_FACTORS, `newton_matrix`)
SPARSE_FACTORS = 2
# rows of the vector workspace: the stage derivatives from V_F, then the last step's history
(V_Y, V_Z, V_BASE, V_DELTA, V_ERR, V_WEIGHT, V_F) = range(7)
V_SLOPE, V_CURVATURE = V_F + MAX_STAGES, V_F + MAX_STAGES + 1
V_ROWS = V_CURVATURE + 1

OK = 0
TOO_MUCH_WORK, STEP_TOO_SMALL, ERROR_TEST_FAILURES, CONVERGENCE_FAILURES, SINGULAR_MATRIX, \
    RHS_FAILURE = -1, -2, -3, -4, -5, -8
FLAG_NAMES = {TOO_MUCH_WORK: "TOO_MUCH_WORK", STEP_TOO_SMALL: "STEP_TOO_SMALL",
              ERROR_TEST_FAILURES: "ERROR_TEST_FAILURES",
              CONVERGENCE_FAILURES: "CONVERGENCE_FAILURES", SINGULAR_MATRIX: "SINGULAR_MATRIX",
              RHS_FAILURE: "RHS_FAILURE"}
