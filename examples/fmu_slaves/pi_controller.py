"""A slave script for `flexure.fmu.build_slave_fmu`: a discrete PI position controller.

    from flexure.fmu import build_slave_fmu
    build_slave_fmu("examples/fmu_slaves/pi_controller.py", "pi_controller.fmu")

At every doStep over [t_k, t_k + h] it reads the measured position x_k and the reference r_k
(m) and sets the force (N) for the next interval,

    e_k = r_k - x_k,    I_k = I_k-1 + h e_k,    F = kp e_k + ki I_k

with the gains kp (N/m) and ki (N/(m s)) as parameters. It is the smallest slave that shows
what `SafeSlave` asks of a script: variables with units, `advance`, and its state as data.
"""

from flexure.core import FlexureError
from flexure.fmu.slave import SafeSlave


class pi_controller(SafeSlave):
    """A PI controller from position error (m) to force (N)."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.author = "flexure"
        self.description = "discrete PI position controller"
        self.x, self.reference, self.F, self.integral = 0.0, 0.0, 0.0, 0.0
        self.kp, self.ki = 1000.0, 20000.0
        self.add_real("x", causality="input", unit="m", start=0.0,
                      description="measured position")
        self.add_real("reference", causality="input", unit="m", start=0.0,
                      description="desired position")
        self.add_real("F", causality="output", unit="N", description="actuator force")
        self.add_real("kp", causality="parameter", unit="N/m", start=self.kp,
                      description="proportional gain")
        self.add_real("ki", causality="parameter", unit="N/(m.s)", start=self.ki,
                      description="integral gain")

    def check_value(self, name, value):
        if name in ("kp", "ki") and not value >= 0.0:
            return f"{name} = {value!r}: expected a gain >= 0"
        return None

    def advance(self, t, h):
        error = self.reference - self.x
        if error != error:  # NaN: refuse the step, keep the state
            raise FlexureError(f"t = {t} s: the position error is not a number")
        self.integral += h * error
        self.F = self.kp * error + self.ki * self.integral

    def save_state(self):
        return {"integral": self.integral, "F": self.F}

    def load_state(self, state):
        self.integral, self.F = float(state["integral"]), float(state["F"])
