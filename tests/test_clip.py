"""The clip directory format: round trip, atomic save, validation on load."""
import json
import math

import numpy as np
import pytest

import sim.clip as clip_module
from sim.clip import PIXEL_FORMAT, Clip, is_clip_dir, load_clip, round_truth, save_clip

FRAMES, HEIGHT, WIDTH = 5, 4, 8


def make_clip(seed: int = 0) -> Clip:
    rng = np.random.default_rng(seed)
    shape = (FRAMES, HEIGHT, 2 * WIDTH)
    hand_xy = round_truth(rng.uniform(0, 8, size=(FRAMES, 2)))
    hand_area = rng.integers(1, 20, size=FRAMES)
    hand_xy[4] = math.nan          # a frame without a visible hand
    hand_area[4] = 0
    return Clip(gesture="stop", seed=seed, fps=30, hand_disparity=40, face_disparity=24,
                motion_frames=(1, 3),
                left=rng.integers(0, 256, size=shape, dtype=np.uint8),
                right=rng.integers(0, 256, size=shape, dtype=np.uint8),
                hand_xy=hand_xy, hand_area=hand_area, renderer={"note": "test", "k": [1, 2]})


def assert_same(a: Clip, b: Clip) -> None:
    assert a.metadata() == b.metadata()
    assert np.array_equal(a.left, b.left) and np.array_equal(a.right, b.right)
    assert np.array_equal(a.hand_xy, b.hand_xy, equal_nan=True)
    assert np.array_equal(a.hand_area, b.hand_area)
    assert np.array_equal(a.moving, b.moving)


@pytest.fixture
def saved(tmp_path):
    path = tmp_path / "clip"
    save_clip(make_clip(), path)
    return path


@pytest.mark.parametrize("mmap", [True, False])
def test_round_trip(saved, mmap):
    loaded = load_clip(saved, mmap=mmap)
    assert_same(loaded, make_clip())
    assert isinstance(loaded.left, np.memmap) == mmap
    assert (loaded.frames, loaded.height, loaded.width) == (FRAMES, HEIGHT, WIDTH)
    assert loaded.moving.tolist() == [False, True, True, True, False]


def test_files_and_json(saved):
    assert sorted(p.name for p in saved.iterdir()) == [
        "clip.json", "left.npy", "right.npy", "truth.csv"]
    meta = json.loads((saved / "clip.json").read_text())
    assert meta["format"] == "stereogest-clip" and meta["version"] == 1
    assert meta["pixel_format"] == PIXEL_FORMAT == "YCbCr 4:2:2, bytes Y0 Cb Y1 Cr"
    assert (meta["width"], meta["height"], meta["frames"]) == (WIDTH, HEIGHT, FRAMES)
    assert meta["motion_frames"] == [1, 3]
    lines = (saved / "truth.csv").read_text().splitlines()
    assert lines[0] == "frame,hand_x,hand_y,hand_area,moving"
    assert len(lines) == FRAMES + 1
    assert lines[5].startswith("4,nan,nan,0,0")
    assert all(len(cell.split(".")[1]) == 2 for cell in lines[1].split(",")[1:3])
    assert is_clip_dir(saved) and not is_clip_dir(saved / "clip.json")


def test_overwrite_existing_clip(saved):
    save_clip(make_clip(seed=1), saved)
    assert_same(load_clip(saved), make_clip(seed=1))
    assert [p.name for p in saved.parent.iterdir()] == ["clip"]   # no leftovers


def test_save_into_empty_directory(tmp_path):
    (tmp_path / "empty").mkdir()
    save_clip(make_clip(), tmp_path / "empty")
    assert is_clip_dir(tmp_path / "empty")


def test_refuses_to_overwrite_non_clip(tmp_path):
    (tmp_path / "file").write_text("precious")
    (tmp_path / "dir").mkdir()
    (tmp_path / "dir" / "notes.txt").write_text("precious")
    for name in ("file", "dir"):
        with pytest.raises(ValueError, match="not a stereogest clip"):
            save_clip(make_clip(), tmp_path / name)
    assert (tmp_path / "file").read_text() == "precious"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir", "file"]


def test_failed_save_leaves_nothing_behind(tmp_path, monkeypatch):
    real_save = np.save
    calls = []

    def failing_save(*args, **kwargs):
        calls.append(args[0])
        if len(calls) == 2:            # right.npy: the disk is "full"
            raise OSError("no space left on device")
        return real_save(*args, **kwargs)

    monkeypatch.setattr(clip_module.np, "save", failing_save)
    with pytest.raises(OSError, match="no space"):
        save_clip(make_clip(), tmp_path / "clip")
    assert list(tmp_path.iterdir()) == []


def test_failed_overwrite_keeps_the_old_clip(saved, monkeypatch):
    def failing_save(*args, **kwargs):
        raise OSError("no space left on device")

    monkeypatch.setattr(clip_module.np, "save", failing_save)
    with pytest.raises(OSError):
        save_clip(make_clip(seed=1), saved)
    monkeypatch.undo()
    assert_same(load_clip(saved), make_clip())
    assert [p.name for p in saved.parent.iterdir()] == ["clip"]


@pytest.mark.parametrize("change, field", [
    (dict(gesture="wave"), "gesture"),
    (dict(hand_disparity=48), "hand_disparity"),
    (dict(motion_frames=(3, 9)), "motion_frames"),
    (dict(hand_area=np.zeros(FRAMES, np.int64)), "hand_x"),
    (dict(right=np.zeros((FRAMES, HEIGHT, 2 * WIDTH + 4), np.uint8)), "right"),
    (dict(left=np.zeros((FRAMES, HEIGHT, 2 * WIDTH), np.int16)), "left"),
])
def test_invalid_clip_is_not_saved(tmp_path, change, field):
    clip = make_clip()
    for key, value in change.items():
        setattr(clip, key, value)
    with pytest.raises(ValueError, match=field):
        save_clip(clip, tmp_path / "clip")
    assert list(tmp_path.iterdir()) == []


def edit_json(path, **changes):
    meta = json.loads((path / "clip.json").read_text())
    for key, value in changes.items():
        if value is None:
            del meta[key]
        else:
            meta[key] = value
    (path / "clip.json").write_text(json.dumps(meta))


@pytest.mark.parametrize("changes, pattern", [
    (dict(format="other"), r"clip\.json.*'format'"),
    (dict(version=2), r"clip\.json.*'version'"),
    (dict(gesture="wave"), r"clip\.json.*'gesture'"),
    (dict(width=WIDTH + 1), r"clip\.json.*'width'.*even"),
    (dict(frames=0), r"clip\.json.*'frames'"),
    (dict(fps=0), r"clip\.json.*'fps'"),
    (dict(face_disparity=-1), r"clip\.json.*'face_disparity'"),
    (dict(motion_frames=[3, 1]), r"clip\.json.*'motion_frames'"),
    (dict(pixel_format="RGB"), r"clip\.json.*'pixel_format'"),
    (dict(seed=None), r"clip\.json.*missing field 'seed'"),
    (dict(frames=FRAMES + 1), r"left\.npy.*shape"),
    (dict(width=WIDTH + 2), r"left\.npy.*shape"),
    (dict(height=HEIGHT - 1), r"left\.npy.*shape"),
])
def test_load_rejects_bad_json_fields(saved, changes, pattern):
    edit_json(saved, **changes)
    with pytest.raises(ValueError, match=pattern):
        load_clip(saved)


def test_load_rejects_corrupted_json(saved):
    (saved / "clip.json").write_text('{"format": "stereogest-clip", "version": ')
    with pytest.raises(ValueError, match=r"clip\.json.*not valid JSON"):
        load_clip(saved)


@pytest.mark.parametrize("mmap", [True, False])
def test_load_rejects_truncated_npy(saved, mmap):
    data = (saved / "right.npy").read_bytes()
    (saved / "right.npy").write_bytes(data[:-7])
    with pytest.raises(ValueError, match=r"right\.npy.*truncated"):
        load_clip(saved, mmap=mmap)
    (saved / "right.npy").write_bytes(data[:40])          # header cut too
    with pytest.raises(ValueError, match=r"right\.npy"):
        load_clip(saved, mmap=mmap)


def test_load_rejects_mismatched_arrays(saved):
    np.save(saved / "right.npy", np.zeros((FRAMES, HEIGHT, 2 * WIDTH - 4), np.uint8))
    with pytest.raises(ValueError, match=r"right\.npy: shape \(5, 4, 12\).*\(5, 4, 16\)"):
        load_clip(saved)
    np.save(saved / "right.npy", np.zeros((FRAMES, HEIGHT, 2 * WIDTH), np.uint16))
    with pytest.raises(ValueError, match=r"right\.npy: dtype must be uint8"):
        load_clip(saved)


@pytest.mark.parametrize("name", ["clip.json", "left.npy", "right.npy", "truth.csv"])
def test_load_rejects_missing_file(saved, name):
    (saved / name).unlink()
    with pytest.raises(ValueError, match=rf"{name.replace('.', r'[.]')}: missing file"):
        load_clip(saved)


def test_load_rejects_bad_truth(saved):
    good = (saved / "truth.csv").read_text()
    lines = good.splitlines()

    def check(text, pattern):
        (saved / "truth.csv").write_text(text)
        with pytest.raises(ValueError, match=pattern):
            load_clip(saved)

    check("\n".join(lines[:-1]) + "\n", r"truth\.csv: has 4 rows.*'frames' is 5")
    check("\n".join(["frame,x,y,area,moving"] + lines[1:]) + "\n", r"truth\.csv: header")
    bad = lines.copy()
    bad[2] = bad[2].rsplit(",", 1)[0] + ",0"       # frame 1 marked not moving
    check("\n".join(bad) + "\n", r"truth\.csv: field 'moving' at frame 1.*'motion_frames'")
    bad = lines.copy()
    bad[3] = "2,abc,1.00,3,1"
    check("\n".join(bad) + "\n", r"truth\.csv: line 4: bad field 'hand_x'")
    bad = lines.copy()
    bad[3] = "7," + bad[3].split(",", 1)[1]
    check("\n".join(bad) + "\n", r"truth\.csv: line 4: field 'frame' must be 2")
    bad = lines.copy()
    bad[2] = "1,nan,nan,5,1"
    check("\n".join(bad) + "\n", r"truth\.csv: hand_x/hand_y must be finite.*frame 1")


def test_load_rejects_non_directory(tmp_path):
    with pytest.raises(ValueError, match="not a clip directory"):
        load_clip(tmp_path / "nowhere")


# ------------------------------------------------------------------ footage


def make_footage(gesture=None) -> Clip:
    rng = np.random.default_rng(7)
    shape = (FRAMES, HEIGHT, 2 * WIDTH)
    return Clip(fps=25, left=rng.integers(0, 256, size=shape, dtype=np.uint8),
                right=rng.integers(0, 256, size=shape, dtype=np.uint8), gesture=gesture,
                source={"left": "left.avi", "right": "right.avi"})


@pytest.mark.parametrize("gesture", [None, "stop"])
def test_footage_round_trip_without_truth(tmp_path, gesture):
    path = save_clip(make_footage(gesture), tmp_path / "footage")
    assert sorted(p.name for p in path.iterdir()) == ["clip.json", "left.npy", "right.npy"]
    meta = json.loads((path / "clip.json").read_text())
    assert not {"seed", "hand_disparity", "face_disparity", "motion_frames"} & meta.keys()
    assert ("gesture" in meta) == (gesture is not None)
    loaded = load_clip(path)
    assert not loaded.has_truth and loaded.moving is None and loaded.hand_xy is None
    assert loaded.gesture == gesture and loaded.source == {"left": "left.avi",
                                                           "right": "right.avi"}
    assert loaded.metadata() == make_footage(gesture).metadata()
    assert np.array_equal(loaded.left, make_footage().left)


def test_footage_rejects_partial_truth(tmp_path):
    path = save_clip(make_footage(), tmp_path / "footage")
    edit_json(path, seed=3)
    with pytest.raises(ValueError, match=r"clip\.json: missing field 'gesture'"):
        load_clip(path)
    edit_json(path, gesture="stop")
    with pytest.raises(ValueError, match=r"clip\.json: missing field 'hand_disparity'"):
        load_clip(path)
    edit_json(path, seed=None, gesture=None)
    (path / "truth.csv").write_text("frame,hand_x,hand_y,hand_area,moving\n")
    with pytest.raises(ValueError, match=r"truth\.csv: present, but clip\.json has no truth"):
        load_clip(path)


def test_footage_clip_is_all_or_nothing_in_memory(tmp_path):
    clip = make_footage()
    clip.motion_frames = (1, 2)
    with pytest.raises(ValueError, match="missing field .gesture."):
        save_clip(clip, tmp_path / "x")
    assert list(tmp_path.iterdir()) == []
