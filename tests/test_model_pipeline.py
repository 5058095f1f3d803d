"""The whole FPGA pipeline model (sim.model.pipeline): per-frame stages on rendered
frames, the per-clip trajectory, parameter validation and run_clip."""
import numpy as np
import pytest

from sim.model.centroid import Centroid, centroid
from sim.model.gesture_spotting import gesture_spotting
from sim.model.moving_average import moving_average
from sim.model.median import median3x3
from sim.model.morphology import dilate, opening
from sim.model.orientation import NO_SYMBOL, orientation_symbols
from sim.model.pipeline import (FrameStages, PipelineParams, Trajectory, process_frame,
                                run_clip, step_symbols, track)
from sim.model.segmentation import disparity_band, hand_mask, skin_mask
from sim.model.stereo import stereo_match
from sim.model.ycbcr import ycbcr422_to_444
from sim.model.posture import PostureReference, next_reference, posture_reference
from sim.render import LAYER_LABELS, StereoScene, render_clip
from soc.hps_interface import POSTURE_WORD_COUNT

# The default parameters are the thesis' values for 640x480; at 320x240 the hand
# (~40 px tall) is still larger than the 29x29 SHD window and the 11x11 opening, while
# at 160x120 the opening erases the moving hand. One frame takes ~50 ms here.
SIZE = dict(width=320, height=240)
SHORT = dict(n_pre_rest=2, n_motion=10, n_post_rest=2)
SCENES = [("rotate-right", 1), ("left", 3)]


@pytest.fixture(scope="module", params=SCENES, ids=lambda s: s[0])
def rendered(request):
    gesture, seed = request.param
    clip = render_clip(gesture, seed, **SIZE, **SHORT)
    scene = StereoScene(gesture, seed, **SIZE, **SHORT)
    frames = range(0, clip.frames, 2)
    stages = {n: process_frame(clip.left[n], clip.right[n]) for n in frames}
    return clip, scene, stages


# ---------------------------------------------------------------- process_frame


def test_hand_centroid_follows_the_truth(rendered):
    clip, scene, stages = rendered
    assert clip.motion_frames == (2, 11)
    for n, st in stages.items():
        assert clip.hand_area[n] > 0                      # the hand is always in view
        assert st.centroid.area > 0, n
        # The opening removes the thin fingers, so the centroid moves towards the palm.
        assert abs(st.centroid.x - clip.hand_xy[n, 0]) <= 5, n
        assert abs(st.centroid.y - clip.hand_xy[n, 1]) <= 5, n
        assert st.centroid.area <= clip.hand_area[n]
        assert st.centroid.area >= clip.hand_area[n] // 3
    # The hand moves by far more than the tolerance, so following it is not by chance.
    xy = np.array([stages[n].centroid[:2] for n in stages])
    assert np.ptp(xy, axis=0).max() > 50


def test_face_is_skin_but_not_hand(rendered):
    clip, scene, stages = rendered
    # SHD aggregation fattens the hand's disparity by up to half the Hamming window,
    # and the opening can move a boundary by its radius: ignore that much around the hand.
    margin = 29 // 2 + 11 // 2
    for n, st in stages.items():
        face = scene.label_map(n) == LAYER_LABELS["face"]
        near_hand = dilate(scene.hand_mask(n), "square", size=2 * margin + 1)
        far_face = face & ~near_hand
        assert st.skin[far_face].mean() > 0.9              # the face is skin colour ...
        assert not st.band[far_face].any()                  # ... outside the band ...
        assert not st.opened[far_face].any()                # ... so never the hand
        assert not (st.opened & ~near_hand).any()           # nothing else is either


def test_frame_stages_types(rendered):
    clip, _, stages = rendered
    st = next(iter(stages.values()))
    assert isinstance(st, FrameStages)
    shape = (clip.height, clip.width)
    for name in ("left", "right", "disparity"):
        arr = getattr(st, name)
        assert arr.shape == shape and arr.dtype == np.uint8, name
    for name in ("skin", "band", "hand", "opened"):
        arr = getattr(st, name)
        assert arr.shape == shape and arr.dtype == bool, name
    assert isinstance(st.centroid, Centroid)
    assert all(type(v) is int for v in st.centroid)
    assert st.disparity.max() <= 47
    assert not (st.opened & ~st.hand).any()           # an opening only removes pixels


def by_hand(left_bytes, right_bytes, *, wc, wh, d, th, cost, cb, cr, low, high, shape, size):
    """The documented stage list, written out with explicit parameters."""
    y_l, cb_l, cr_l = ycbcr422_to_444(left_bytes)
    y_r, _, _ = ycbcr422_to_444(right_bytes)
    y_l, y_r = median3x3(y_l), median3x3(y_r)
    disp = stereo_match(y_l, y_r, census_window=wc, hamming_window=wh, max_disparity=d,
                        lrcc_threshold=th, no_match_cost=cost).disparity
    skin = skin_mask(cb_l, cr_l, cb, cr)
    band = disparity_band(disp, low, high, d)
    hand = hand_mask(skin, band)
    opened = opening(hand, shape, size=size)
    return (y_l, y_r, disp, skin, band, hand, opened, centroid(opened))


THESIS = dict(wc=7, wh=29, d=48, th=8, cost=24 // 3, cb=(77, 127), cr=(133, 173),
              low=33, high=46, shape="cross", size=11)
OTHER = dict(wc=5, wh=21, d=44, th=3, cost=5, cb=(80, 125), cr=(135, 170),
             low=30, high=43, shape="square", size=5)


def other_params():
    o = OTHER
    return PipelineParams(census_window=o["wc"], hamming_window=o["wh"], max_disparity=o["d"],
                          lrcc_threshold=o["th"], no_match_cost=o["cost"], skin_cb=o["cb"],
                          skin_cr=o["cr"], band_low=o["low"], band_high=o["high"],
                          opening_shape=o["shape"], opening_size=o["size"])


def test_stages_are_composed_as_documented():
    clip = render_clip("stop", 2, **SIZE, **SHORT)
    n = 6
    got = process_frame(clip.left[n], clip.right[n])
    expected = by_hand(clip.left[n], clip.right[n], **THESIS)
    for name, a, b in zip(FrameStages._fields, got, expected):
        assert np.array_equal(a, b), name
    # Every parameter reaches its stage: other values, other (but again composed) stages.
    got_other = process_frame(clip.left[n], clip.right[n], other_params(), threads=2)
    expected_other = by_hand(clip.left[n], clip.right[n], **OTHER)
    for name, a, b in zip(FrameStages._fields, got_other, expected_other):
        assert np.array_equal(a, b), name
    for name in ("disparity", "skin", "band", "opened"):
        assert not np.array_equal(getattr(got, name), getattr(got_other, name)), name


def test_process_frame_size_mismatch():
    clip = render_clip("stop", 2, width=96, height=64, n_pre_rest=0, n_motion=2, n_post_rest=0)
    with pytest.raises(ValueError, match="differ in size"):
        process_frame(clip.left[0], clip.right[0][:, :-4], PipelineParams(max_disparity=32))


# ---------------------------------------------------------------- track / step_symbols


def loop_step_symbols(smoothed, flag):
    out = []
    for n in range(len(flag)):
        if n == 0 or not (flag[n] and flag[n - 1]):
            out.append(NO_SYMBOL)
        else:
            out.append(int(orientation_symbols(np.array([smoothed[n - 1], smoothed[n]]))[0]))
    return out


def test_step_symbols_hand_made():
    s = 256
    smoothed = np.array([[0, 0], [s, 0], [s, 0], [s, -s], [0, -s], [0, 0], [-s, s]])
    all_flagged = np.ones(7, bool)
    # right, no motion, up, left, down, down-left (y grows downward)
    assert step_symbols(smoothed, all_flagged).tolist() == [NO_SYMBOL, 0, NO_SYMBOL, 2, 4, 6, 5]
    flag = np.array([1, 1, 1, 1, 0, 1, 1], bool)
    # frame 4 unflagged, frame 5's predecessor unflagged
    assert step_symbols(smoothed, flag).tolist() == [NO_SYMBOL, 0, NO_SYMBOL, 2, NO_SYMBOL,
                                                     NO_SYMBOL, 5]
    out = step_symbols(smoothed, np.zeros(7, bool))
    assert out.dtype == np.int8 and (out == NO_SYMBOL).all()
    assert step_symbols(smoothed[:1], [True]).tolist() == [NO_SYMBOL]
    assert step_symbols(np.zeros((0, 2), np.int64), np.zeros(0, bool)).tolist() == []


def test_step_symbols_matches_loop_reference():
    rng = np.random.default_rng(5)
    smoothed = rng.integers(-3, 4, (300, 2)).cumsum(axis=0) * 64
    flag = rng.random(300) < 0.7
    assert step_symbols(smoothed, flag).tolist() == loop_step_symbols(smoothed, flag)


def swipe(rest=10, moving=20, still=30, step=8):
    """A centroid at rest, moving right by ``step`` px per frame, then at rest."""
    x = np.concatenate([np.full(rest, 100), 100 + step * np.arange(1, moving + 1),
                        np.full(still, 100 + step * moving)])
    return np.stack([x, np.full_like(x, 200)], axis=1).astype(np.int64)


def test_track_equals_the_stages_composed_by_hand():
    rng = np.random.default_rng(6)
    cents = swipe() + rng.integers(-1, 2, (60, 2))
    areas = rng.integers(50, 500, 60)
    areas[[0, 1, 2, 15, 16, 40]] = 0
    cents[areas == 0] = 0                               # as centroid() reports no hand
    for params in (PipelineParams(), PipelineParams(average_window=8, frac_bits=6,
                                                     spot_window=4, spot_threshold=12,
                                                     spot_hold=5)):
        got = track(cents, areas, params)
        assert isinstance(got, Trajectory)
        valid = areas > 0
        smoothed = moving_average(cents, valid, params.average_window, params.frac_bits)
        primed = np.array([valid[:n + 1].any() for n in range(60)])
        flag = gesture_spotting(smoothed, primed, params.spot_window, params.spot_threshold,
                                params.spot_hold, params.frac_bits)
        assert np.array_equal(got.centroid, cents) and np.array_equal(got.area, areas)
        assert np.array_equal(got.smoothed, smoothed)
        assert np.array_equal(got.flag, flag)
        assert got.symbol.tolist() == loop_step_symbols(smoothed, flag)
        assert got.smoothed.dtype == np.int64 and got.smoothed.shape == (60, 2)
        assert got.flag.dtype == bool and got.symbol.dtype == np.int8


def test_track_flags_a_swipe_and_gives_its_direction():
    cents = swipe()
    t = track(cents, np.full(60, 100))
    assert not t.flag[:10].any()                        # at rest
    # Frame 14 averages x = 116..140 -> 128, 28 px from frame 6's 100: not yet moving;
    # frame 15 averages 124..148 -> 136, 36 px > Tm = 30 from frame 7.
    assert not t.flag[14] and t.flag[15:30].all()
    assert not t.flag[-5:].any()                        # 16 still frames end it
    moving = t.flag & (t.symbol != NO_SYMBOL)
    assert moving.sum() >= 10 and (t.symbol[moving] == 0).all()   # to the right (+x)
    assert (t.symbol[~t.flag] == NO_SYMBOL).all()


def test_track_holds_the_average_when_no_hand():
    cents = swipe()
    areas = np.full(60, 100)
    lost = [0, 1, 12, 13, 14, 25, 50]
    areas[lost] = 0
    t = track(cents, areas)
    assert not t.smoothed[:2].any()                     # no hand yet: (0, 0)
    for n in lost[2:]:
        assert np.array_equal(t.smoothed[n], t.smoothed[n - 1]), n
    # What a lost frame's centroid says does not matter.
    garbage = cents.copy()
    garbage[lost] = [[639, 479]]
    t2 = track(garbage, areas)
    assert np.array_equal(t.smoothed, t2.smoothed) and np.array_equal(t.flag, t2.flag)
    # Unprimed frames are never flagged; the first valid one fills the average.
    assert not t.flag[:2].any() and np.array_equal(t.smoothed[2], cents[2] * 256)


def test_track_edge_cases():
    t = track(np.zeros((0, 2)), np.zeros(0))
    assert all(len(a) == 0 for a in t[:-1]) and t.posture is None
    t = track([[5, 7]], [0])
    assert t.smoothed.tolist() == [[0, 0]] and t.flag.tolist() == [False]
    with pytest.raises(ValueError, match="differ in length"):
        track(np.zeros((4, 2)), np.zeros(3))


# ---------------------------------------------------------------- PipelineParams


def test_defaults_are_valid_and_thesis_values():
    params = PipelineParams()
    params.validate(640, 480)
    assert (params.census_window, params.hamming_window, params.max_disparity,
            params.band_low, params.opening_size, params.average_window,
            params.spot_window, params.spot_threshold) == (7, 29, 48, 33, 11, 4, 8, 30)
    assert params.as_dict()["skin_cb"] == (77, 127)


@pytest.mark.parametrize("kwargs, name", [
    (dict(band_low=40, band_high=40), "band_high"),
    (dict(band_low=40, band_high=35), "band_high"),
    (dict(band_low=-1), "band_low"),
    (dict(band_high=48), "band_high"),
    (dict(opening_size=10), "opening_size"),
    (dict(opening_shape="star"), "opening_shape"),
    (dict(average_window=3), "average_window"),
    (dict(spot_window=0), "spot_window"),
    (dict(spot_threshold=-1), "spot_threshold"),
    (dict(spot_hold=0), "spot_hold"),
    (dict(frac_bits=17), "frac_bits"),
    (dict(skin_cb=(130, 120)), "skin_cb"),
    (dict(skin_cr=(1,)), "skin_cr"),
    (dict(lrcc_threshold=0), "lrcc_threshold"),
    (dict(census_window=13), "census_window"),
    (dict(hamming_window=30), "hamming_window"),
    (dict(no_match_cost=25), "no_match_cost"),
    (dict(max_disparity=321), "max_disparity"),
    (dict(track_gate=-1), "track_gate"),
    (dict(hand_rows=5000), "hand_rows"),
])
def test_validate_names_the_parameter(kwargs, name):
    with pytest.raises(ValueError, match=rf"^{name}\b"):
        PipelineParams(**kwargs).validate(320, 240)


def test_validate_frame_size():
    with pytest.raises(ValueError, match="width"):
        PipelineParams().validate(8, 240)
    with pytest.raises(ValueError, match="height"):
        PipelineParams().validate(320, 4097)
    with pytest.raises(ValueError, match=r"^width must be in \[48, 4096\], got 40"):
        PipelineParams().validate(40, 240)          # D = 48 > width
    with pytest.raises(ValueError, match=r"^width must be even, in \[48, 4096\]"):
        PipelineParams().validate(321, 240)
    PipelineParams().validate(48, 16)               # the smallest frame, both bounds


@pytest.mark.parametrize("kwargs, low", [
    ({}, 48),                                       # D
    (dict(max_disparity=16, lrcc_threshold=4, band_low=4), 30),    # Wh + 1
    (dict(max_disparity=8, lrcc_threshold=4, band_low=2, hamming_window=9), 16),  # the floor
    (dict(max_disparity=8, lrcc_threshold=4, band_low=2, hamming_window=9,
          opening_size=21), 24),                                        # W + 2 = 23, even
    (dict(max_disparity=33, band_low=20), 34),      # rounded up to even
])
def test_width_range_is_what_validate_enforces(kwargs, low):
    """The one width range a command states is the one the pipeline checks."""
    params = PipelineParams(**kwargs)
    assert params.width_range() == (low, 4096)
    params.validate(low, 240)
    with pytest.raises(ValueError, match=rf"^width must be .*\[{low}, 4096\]"):
        params.validate(low - 2, 240)


def test_for_frame_hand_tracking_scales_with_the_width():
    from sim.model.pipeline import HAND_TRACKING_640
    assert not PipelineParams.for_frame(640).hand_tracking
    thesis = PipelineParams()
    assert (thesis.track_gate, thesis.hand_rows) == (0, 0) and not thesis.hand_tracking
    at_640 = PipelineParams.for_frame(640, hand_tracking=True)
    assert at_640.hand_tracking
    assert {name: getattr(at_640, name) for name in HAND_TRACKING_640} == HAND_TRACKING_640
    at_320 = PipelineParams.for_frame(320, hand_tracking=True)
    assert {name: getattr(at_320, name) for name in HAND_TRACKING_640} == \
        {name: value // 2 for name, value in HAND_TRACKING_640.items()}
    assert PipelineParams.for_frame(320, hand_tracking=True, hand_rows=0).hand_rows == 0


# ---------------------------------------------------------------- run_clip


@pytest.fixture(scope="module")
def small_clip():
    return render_clip("rotate-left", 7, width=160, height=120, n_pre_rest=1, n_motion=3,
                       n_post_rest=1)


def test_run_clip_keep_progress_and_trajectory(small_clip):
    clip = small_clip
    calls = []
    traj, kept = run_clip(clip.left, clip.right, keep=lambda n: n in (1, 3),
                          progress=lambda done, total: calls.append((done, total)))
    assert calls == [(n, 5) for n in range(1, 6)]
    assert sorted(kept) == [1, 3]
    # the posture is described about a reference predicted from the last two frames' own
    each, own = [], [PostureReference(0, 0, 0)] * 2
    for n in range(clip.frames):
        reference = next_reference(own[-1], own[-2], clip.width, clip.height)
        each.append(process_frame(clip.left[n], clip.right[n], reference=reference,
                                  posture_previous=own[-1] if n else None))
        own.append(posture_reference(each[-1].posture))
    for n in (1, 3):
        for name, a, b in zip(FrameStages._fields, kept[n], each[n]):
            assert (a == b if isinstance(a, tuple) else np.array_equal(a, b)), (n, name)
    assert each[3].posture_reference == next_reference(own[4], own[3], clip.width, clip.height)
    assert each[2].following()["reference"] == each[3].posture_reference
    expected = track([st.centroid[:2] for st in each], [st.centroid.area for st in each],
                     posture=[st.posture_words() for st in each])
    assert traj.posture.shape == (clip.frames, POSTURE_WORD_COUNT)
    for name, a, b in zip(Trajectory._fields, traj, expected):
        assert np.array_equal(a, b), name
    # Default: keep nothing.
    traj2, kept2 = run_clip(clip.left[:2], clip.right[:2])
    assert kept2 == {} and len(traj2.flag) == 2


def test_run_clip_errors(small_clip):
    clip = small_clip
    with pytest.raises(ValueError, match="frames"):
        run_clip(clip.left, clip.right[:-1])
    calls = []
    with pytest.raises(ValueError, match="census_window"):   # validated before any frame
        run_clip(clip.left, clip.right, PipelineParams(census_window=13),
                 progress=lambda done, total: calls.append(done))
    assert calls == []
    with pytest.raises(ValueError, match=r"width must be in \[200, "):   # D = 200 > 160 px
        run_clip(clip.left, clip.right, PipelineParams(max_disparity=200))


def test_run_clip_hands_each_frame_the_previous_centroid():
    """Hand tracking on a forearm and an intruder (sim/difficulties.py): run_clip
    passes each frame's centroid to the next, and the tracked centroid stays on
    the hand where the thesis' is dragged down the arm."""
    from sim.difficulties import Difficulties
    clip = render_clip("right", 5, **SIZE, n_pre_rest=2, n_motion=12, n_post_rest=0,
                       difficulties=Difficulties(forearm=True, intruder=True))
    tracking = PipelineParams.for_frame(SIZE["width"], hand_tracking=True)
    traj, kept = run_clip(clip.left, clip.right, tracking, keep=lambda n: True)
    previous, chained = None, []
    for n in range(clip.frames):
        previous = centroid(kept[n].opened, previous=previous,
                            track_gate=tracking.track_gate, hand_rows=tracking.hand_rows)
        chained.append(tuple(previous))
    assert [tuple(c) + (a,) for c, a in zip(traj.centroid, traj.area)] == chained
    assert [tuple(kept[n].centroid) for n in range(clip.frames)] == chained
    thesis = [centroid(kept[n].opened) for n in range(clip.frames)]
    error = np.hypot(*(traj.centroid - clip.hand_xy).T)
    thesis_error = np.hypot(*(np.array([c[:2] for c in thesis]) - clip.hand_xy).T)
    assert error.mean() < 6 and thesis_error.mean() > 3 * error.mean()
