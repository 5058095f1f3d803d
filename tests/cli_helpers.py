"""Helpers shared by the command-line tests."""
from stereogest import cli


def run(capsys, *argv):
    """(exit status, stdout, stderr) of ``stereogest argv``, run in-process."""
    status = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


def assert_one_line_error(err, command, *words):
    """stderr is one ``stereogest COMMAND: error: ...`` line holding every word."""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"stereogest {command}: error: ")
    assert "Traceback" not in err
    for word in words:
        assert word in lines[0], (word, lines[0])
