"""The [actuators] of a scene: voice-coil actuators, each driving one of the scene's inputs.

    [actuators.VCM1]
    input = "F1"             # the input it drives: that input becomes its drive signal (V)
    force_constant = 10.0    # Km, N/A (= back-EMF constant, V s/m)
    resistance = 2.0         # R, ohm
    inductance = 1.0e-3      # L, H
    drive = "voltage"        # "voltage" (default) or "current"
    amplifier_gain = 1.0     # G, V/V or A/V (default 1)
    saturation = 24.0        # the amplifier's output limit, V or A (optional: none)

A voltage drive needs R > 0 and L > 0 (its coil current is a state); a current drive
absorbs the coil's voltage, so its R and L may be given (a scene switched between drives by
`--set`) but do not act. The equations: `flexure.core.mechanics.actuators`.
"""

from dataclasses import replace

from ..model import CURRENT, VOLTAGE, Actuator
from .scene_reader import show

ACTUATOR_KEYS = {"input", "force_constant", "resistance", "inductance", "drive",
                 "amplifier_gain", "saturation"}
DRIVES = (VOLTAGE, CURRENT)
DRIVE_UNIT = "V"  # the drive signal of either amplifier is a voltage (gain V/V or A/V)


class ActuatorBuilding:
    """The scene builder's part for [actuators]; uses the builder's checked reading
    (`SceneReader`) and the inputs already built."""

    def build_actuators(self, table, inputs):
        """(actuators, inputs): the [actuators] entries, and the inputs with each driven one
        turned into its drive signal (quantity "drive", unit V)."""
        actuators = []
        for name, entry in self.table("actuators", table).items():
            with self.entry():  # collected, so every entry is checked
                actuators.append(self.build_actuator(name, entry, inputs, actuators))
        self.raise_problems()
        actuators.sort(key=lambda a: a.input)  # in the order of the inputs they drive
        driven = {a.input for a in actuators}
        inputs = [replace(port, quantity="drive", unit=DRIVE_UNIT) if i in driven else port
                  for i, port in enumerate(inputs)]
        return actuators, inputs

    def build_actuator(self, name, entry, inputs, actuators):
        """One [actuators.NAME]: its input, coil and amplifier, checked."""
        key = f"actuators.{name}"
        entry = self.table(key, entry)
        if not name.isidentifier():
            self.fail(key, "an actuator name must be an identifier (letters, digits, _)")
        self.check_keys(key, entry, ACTUATOR_KEYS)
        for required in ("input", "force_constant"):
            if required not in entry:
                self.fail(key, f"missing {required!r}")
        names = [port.name for port in inputs]
        input_name = entry["input"]
        if not isinstance(input_name, str) or input_name not in names:
            self.fail(f"{key}.input", f"unknown input {show(input_name)}; the scene's inputs: "
                                      f"{', '.join(names) or 'none'}")
        index = names.index(input_name)
        for other in actuators:
            if other.input == index:
                self.fail(f"{key}.input", f"input {input_name!r} is driven by "
                                          f"actuators.{other.name} already; one actuator per "
                                          "input")
        drive = entry.get("drive", VOLTAGE)
        if drive not in DRIVES:
            self.fail(f"{key}.drive", f"expected one of {', '.join(DRIVES)}, got {show(drive)}")
        if drive == VOLTAGE:
            for needed in ("resistance", "inductance"):
                if needed not in entry:
                    self.fail(key, f"missing {needed!r}: a voltage-driven coil needs its "
                                   "resistance (ohm) and inductance (H); or drive = \"current\"")
        positive = {k: self.number(f"{key}.{k}", entry[k], positive=True)
                    for k in ("force_constant", "resistance", "inductance", "amplifier_gain",
                              "saturation") if k in entry}
        return Actuator(name=name, input=index, force_constant=positive["force_constant"],
                        resistance=positive.get("resistance", 0.0),
                        inductance=positive.get("inductance", 0.0), drive=drive,
                        amplifier_gain=positive.get("amplifier_gain", 1.0),
                        saturation=positive.get("saturation", float("inf")))
