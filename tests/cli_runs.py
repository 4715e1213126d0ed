"""Running the `flexure` command in the test process, as a user's shell would."""

from flexure.core.cli import main


def run(capsys, *argv):
    """(exit code, stdout, stderr) of `flexure ARGV` in this process; never a traceback."""
    try:
        code = main([str(a) for a in argv])
    except SystemExit as stop:  # argparse: exit 2 with its message
        code = stop.code
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err
