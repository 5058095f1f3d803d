"""sim/atomic.py: a file written whole or not at all."""
import pytest

from sim.atomic import write_text_atomic


def test_write_and_replace(tmp_path):
    path = tmp_path / "a.json"
    assert write_text_atomic(path, "one") == path and path.read_text() == "one"
    write_text_atomic(path, "two")
    assert path.read_text() == "two" and [p.name for p in tmp_path.iterdir()] == ["a.json"]


def test_a_failure_leaves_the_old_file_and_no_temporary(tmp_path):
    path = tmp_path / "a.json"
    path.write_text("old")
    with pytest.raises(TypeError):
        write_text_atomic(path, 42)
    assert path.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["a.json"]
