"""A slave's fmi2SetReal and fmi2GetReal while stepping: once the host's usual calls have
made their tables, every other call is answered as the first call of an instance is (which
goes the checked way): the same values stored and read, the same error state, the same log.
"""

import pytest

from flexure.fmu.slave import SafeSlave

U, W, Y, FIXED, GAIN, FLAKY, BAD = range(7)  # value references, in the order added


class Probe(SafeSlave):
    """Unchecked inputs u and flaky (whose setter raises once armed), a checked input w
    (refusing a negative value), an output y, a fixed and a tunable parameter, and an output
    whose getter raises."""

    unchecked_inputs = frozenset({"u", "flaky"})

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.u, self.w, self.fixed, self.gain, self.flaky = 0.0, 0.0, 1.0, 2.0, 0.0
        self.armed = False
        self.add_real("u", causality="input", start=0.0)
        self.add_real("w", causality="input", start=0.0)
        self.add_real("y", causality="output", getter=lambda: self.gain * self.u)
        self.add_real("fixed", causality="parameter", start=1.0)  # fixed: a parameter's default
        self.add_real("gain", causality="parameter", start=2.0)
        self.add_real("flaky", causality="input", start=0.0, setter=self.set_flaky)
        self.add_real("bad", causality="output", getter=self.fail)

    def set_flaky(self, value):
        if self.armed:
            self.armed = False
            raise RuntimeError("the setter failed once")
        self.flaky = value

    def fail(self):
        raise RuntimeError("the getter failed")

    def check_value(self, name, value):
        return f"{name} = {value!r}: expected >= 0" if value < 0.0 else None

    def advance(self, t, h):
        pass


def _stepping(warm):
    """A probe in step complete; `warm`: after the host's usual set and get (u, y)."""
    probe = Probe(instance_name="p")
    probe.setup_experiment(0.0)
    probe.enter_initialization_mode()
    probe.exit_initialization_mode()
    if warm:
        probe.set_real([U], [0.0])  # the value it has: the two probes stay alike
        probe.get_real([Y])
    probe.armed = True
    return probe


def _outcome(probe):
    """The values, the error state and the log (each message's first line: a traceback
    below it names the lines it passed through)."""
    return (probe.u, probe.w, probe.fixed, probe.gain, probe.flaky, probe.broken,
            [(m.status, m.msg.splitlines()[0]) for m in probe.log_queue])


SETS = {
    "one input": ([U], [2.0]),
    "an unchecked and a checked input": ([U, W], [2.0, 3.0]),
    "a checked input refused": ([U, W], [2.0, -1.0]),
    "an output": ([U, Y], [2.0, 3.0]),
    "an unknown reference": ([U, 99999], [2.0, 3.0]),
    "a fixed parameter while stepping": ([FIXED], [5.0]),
    "a tunable parameter": ([GAIN], [5.0]),
    "more values than references": ([U], [2.0, 3.0]),
    "fewer values than references": ([U, W], [2.0]),
    "a setter that raises": ([U, FLAKY], [2.0, 3.0]),
    "not a list": (None, None),
}


@pytest.mark.parametrize("case", SETS)
def test_a_set_while_stepping_is_answered_as_an_instances_first_set(case):
    vrs, values = SETS[case]
    first, warm = _stepping(warm=False), _stepping(warm=True)
    first.set_real(vrs, values)
    warm.set_real(vrs, values)
    assert _outcome(warm) == _outcome(first)


def test_the_usual_set_stores_and_a_refused_one_enters_the_error_state():
    """What the comparison above rests on, stated: an unchecked input is stored; a fixed
    parameter while stepping is refused; a setter that raises is refused (not tried again,
    which would succeed)."""
    probe = _stepping(warm=True)
    probe.set_real([FIXED], [5.0])
    assert probe.fixed == 1.0 and "'fixed' (value reference 3) is a fixed parameter" in \
        probe.broken
    probe = _stepping(warm=True)
    probe.set_real([U], [2.0])
    assert probe.u == 2.0 and not probe.broken
    probe.set_real([U, FLAKY], [3.0, 4.0])
    assert probe.broken and "the setter failed once" in probe.broken
    assert probe.flaky == 0.0


@pytest.mark.parametrize("variability", ["fixed", "tunable", "constant"])
def test_an_input_that_a_host_could_not_set_while_stepping_is_refused_when_added(variability):
    class Wrong(SafeSlave):
        def __init__(self, **kwargs):
            super().__init__(**kwargs)
            self.u = 0.0
            self.add_real("u", causality="input", variability=variability, start=0.0)

    with pytest.raises(ValueError, match=f"u: an input is continuous or discrete "
                                         rf"\(FMI 2.0\), not {variability}"):
        Wrong(instance_name="w")


GETS = {
    "an input and an output": [U, Y],
    "an unknown reference": [U, 99999],
    "a getter that raises": [BAD, Y],
    "no references": [],
}


@pytest.mark.parametrize("case", GETS)
def test_a_get_while_stepping_is_answered_as_an_instances_first_get(case):
    first, warm = _stepping(warm=False), _stepping(warm=True)
    assert repr(warm.get_real(GETS[case])) == repr(first.get_real(GETS[case]))
    assert _outcome(warm) == _outcome(first)
