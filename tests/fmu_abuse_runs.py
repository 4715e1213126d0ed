"""Running an FMU abuse case (fmu_abuse_cases.py) in a subprocess and reading what it printed:
the exit code, the status of each FMI call, the FMU's log and the values the case observed.
"""

import os
import re
import sys
import tempfile
from pathlib import Path

import children

CASES = Path(__file__).with_name("fmu_abuse_cases.py")

FATAL = "-> FATAL"


class Run:
    def __init__(self, done):
        self.code, self.out, self.err = done.returncode, done.stdout, done.stderr
        self.lines = self.out.splitlines()

    def calls(self, function):
        return [line.rsplit("-> ", 1)[1] for line in self.lines
                if line.startswith(f"CALL {function} ")]

    def logs(self):
        return [line.split(" ", 2)[2] for line in self.lines if line.startswith("LOG ")]

    def value(self, key):
        found = [line[len("VALUE ") + len(key) + 1:] for line in self.lines
                 if line.startswith(f"VALUE {key} ")]
        assert found, f"no VALUE {key} in:\n{self.out}\n{self.err}"
        return found[-1]

    def survived(self):
        """The case ran to its end, the process exited cleanly, no call answered Fatal."""
        assert self.code == 0 and self.lines[-1:] == ["SURVIVED"], (
            f"exit code {self.code}\n{self.out[-3000:]}\n{self.err[-3000:]}")
        assert not [line for line in self.lines if line.endswith(FATAL)], self.out
        assert "corrupted" not in self.err and "double free" not in self.err, self.err
        return self


def run(case, fmus, *, env=None, timeout=600):
    stage, truss = fmus
    # the folders fmpy unzips the FMUs into, removed whether or not the case crashed
    with tempfile.TemporaryDirectory(prefix="fmu_abuse_") as unzipped:
        done = children.run([sys.executable, str(CASES), case, str(stage), str(truss)],
                            capture_output=True, text=True, timeout=timeout,
                            env=dict(os.environ, TMPDIR=unzipped, **(env or {})))
    return Run(done)


def refused_then_unchanged(result, message, *, answer="ERROR"):
    """Every state restore answered `answer` (fmi2Error from flexure's corrected pythonfmu
    binary; "OK" from the stock one, which ignores the refusal) with an error log naming why,
    and the instance went on as it was."""
    restores = result.calls("fmi2SetFMUstate")
    assert restores and set(restores) == {answer}, result.out
    refusals = [m for m in result.logs() if "fmi2SetFMUstate refused" in m]
    assert len(refusals) == len(restores), result.out
    assert all(re.search(message, m) and "the instance is unchanged" in m for m in refusals), \
        refusals
    assert result.value("unchanged") == "True"
    assert result.value("steps-on") == "OK"
