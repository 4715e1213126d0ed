"""The [actuators] of a scene: voice-coil actuators, each driving one of the scene's inputs.

    [actuators.VCM1]
    input = "F1"             # the input it drives: that input becomes its drive signal (V)
    force_constant = 10.0    # Km, N/A (= back-EMF constant, V s/m)
    resistance = 2.0         # R, ohm
    inductance = 1.0e-3      # L, H
    drive = "voltage"        # "voltage" (default) or "current"
    amplifier_gain = 1.0     # G, V/V or A/V (default 1)
    saturation = 24.0        # the amplifier's output limit, V or A (optional: none)

The input may be a force on a coordinate or a moment about a global axis of a 3-D rotational
node (a rotary voice coil: Km in N m/A). A voltage drive needs R > 0 and L > 0 (its coil
current is a state); a current drive absorbs the coil's voltage, so its R and L may be given
(a scene switched between drives by `--set`) but do not act. The equations:
`flexure.core.mechanics.actuators`.
"""

from dataclasses import replace

from ..elements.protocol import SchemaKey
from ..model import CURRENT, VOLTAGE, Actuator
from .scene_reader import show

# The numbers an actuator takes, with their units (a tunable FMU parameter's unit:
# `building.scene_key`; `actuator_key` gives the ones that depend on the actuator).
ACTUATOR_KEYS = {key.name: key for key in (
    SchemaKey("force_constant", "N/A", "force constant Km, = back-EMF constant (V s/m)",
              positive=True),
    SchemaKey("resistance", "Ohm", "coil resistance R", positive=True),
    SchemaKey("inductance", "H", "coil inductance L", positive=True),
)}
TEXT_KEYS = {"input", "drive"}
GAIN_KEYS = {"amplifier_gain", "saturation"}  # units by the drive: V/V, V or A/V, A
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
        self.check_keys(key, entry, set(ACTUATOR_KEYS) | TEXT_KEYS | GAIN_KEYS)
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


def actuator_key(model, key):
    """The SchemaKey of "actuators.NAME.KEY" for a number of actuator NAME of `model`, with
    the unit of that actuator: Km in N/A, or N.m/A when its port is a moment or an angle;
    the amplifier's gain 1 (V/V) or A/V and its saturation V or A by its drive. None for a
    key that is not an actuator's number."""
    table, _, rest = key.partition(".")
    name, _, last = rest.rpartition(".")
    found = [a for a in model.actuators if a.name == name]
    if table != "actuators" or not found:
        return None
    actuator = found[0]
    port = model.inputs[actuator.input]
    voltage = actuator.drive == VOLTAGE
    if last == "force_constant" and (port.about_axis
                                     or port.coordinate not in model.translations):
        return replace(ACTUATOR_KEYS[last], unit="N.m/A",
                       meaning="torque constant Km, = back-EMF constant (V s/rad)")
    if last == "amplifier_gain":
        return SchemaKey(last, "1" if voltage else "A/V", "amplifier gain G", positive=True)
    if last == "saturation":
        return SchemaKey(last, "V" if voltage else "A", "amplifier output limit",
                         positive=True)
    return ACTUATOR_KEYS.get(last)
