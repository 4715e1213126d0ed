"""The compiled evaluation engine: the model packed for numba, kinematics, inertia, equations of
motion and their tangent in one place."""
