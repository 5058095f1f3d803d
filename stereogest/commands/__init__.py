"""One module per ``stereogest`` subcommand.

Each module defines ``NAME``, ``HELP``, ``add_arguments(parser)`` and
``run(args) -> int``; :mod:`stereogest.cli` lists them in pipeline order.
"""

#: The ``--seed`` every command takes by default (render, demo, gestures, train,
#: timing): one value, so a command run without it is reproducible and alike.
DEFAULT_SEED = 1


def add_camera_options(parser, *, required: bool) -> None:
    """``--left`` and ``--right``, the two cameras' footage (read by
    :class:`sim.footage.StereoSource`), worded once for ``clip`` and ``live``."""
    import argparse
    default = argparse.SUPPRESS if required else None
    parser.add_argument("--left", required=required, metavar="SOURCE", default=default,
                        help="left camera: a camera index (0, 1, ...), a video file, a "
                             "folder of images or a glob pattern (quote it)")
    parser.add_argument("--right", required=required, metavar="SOURCE", default=default,
                        help="right camera, as --left")


def add_calibration_options(parser) -> None:
    """``--calibration`` and ``--interpolation``: rectify both cameras with the
    maps of a calibration file (``stereogest calibrate``), as the hardware's
    rectification stage does."""
    parser.add_argument("--calibration", metavar="CALIB.json", default=None,
                        help="rectify both cameras first with this calibration "
                             "(stereogest calibrate); its image size must be the frames'")
    parser.add_argument("--interpolation", choices=("bilinear", "nearest"),
                        default="bilinear", help="pixel interpolation of the rectification")


def add_hand_tracking_option(parser) -> None:
    """``--hand-tracking``: the centroid's hand tracking (not in the thesis; the
    gate and top rows of :data:`sim.model.pipeline.HAND_TRACKING_640`, scaled to
    the width), worded once for demo, pipeline, live, generate, timing and
    resources."""
    parser.add_argument("--hand-tracking", action="store_true",
                        help="the centroid counts only the top rows of the mask near the "
                             "last centroid (a forearm or a second skin-coloured thing at "
                             "the hand's depth no longer drags it; not in the thesis)")


def add_vga_scale_option(parser) -> None:
    """``--vga-scale``: the resolution of the VGA debug view's frame buffer
    (:class:`soc.frame_buffer.FrameBuffer`), worded once for demo, generate and
    resources; :func:`vga_scale_of` checks it."""
    from soc.frame_buffer import VGA_SCALE
    parser.add_argument("--vga-scale", type=int, default=VGA_SCALE, metavar="1|2",
                        help="VGA debug view (thesis Table 22): 1 stores every pixel, 2 every "
                             "second pixel of every second row, shown as 2x2 blocks (a "
                             "quarter of the block RAM)")


def vga_scale_of(args) -> int:
    """``--vga-scale``, refused (``ValueError`` naming the option and its range)
    unless in :data:`sim.model.vga.SCALE_RANGE`."""
    from sim.model.validation import check_int
    from sim.model.vga import SCALE_RANGE
    return check_int("--vga-scale", args.vga_scale, *SCALE_RANGE)


def load_rectification(args, width: int, height: int):
    """The :class:`sim.model.rectify.StereoRectification` of ``--calibration``
    for ``width`` x ``height`` frames, or None without the option; errors name
    the option."""
    if getattr(args, "calibration", None) is None:
        return None
    from sim.calibration import load_calibration, stereo_rectification
    try:
        calib = load_calibration(args.calibration)
        return stereo_rectification(calib, width, height, interpolation=args.interpolation)
    except FileNotFoundError:
        raise ValueError(f"--calibration: {args.calibration} does not exist") from None
    except IsADirectoryError:
        raise ValueError(f"--calibration: {args.calibration} is a directory") from None
    except ValueError as exc:
        raise ValueError(f"--calibration: {exc}") from None


def add_scene_options(parser) -> None:
    """``--scene`` and one option per scene difficulty (:mod:`sim.difficulties`),
    worded once for ``render`` and ``demo``."""
    from sim.difficulties import RANGES, SCENES
    hard = parser.add_argument_group(
        "scene difficulties (sim/difficulties.py); each option overrides the --scene's value")
    hard.add_argument("--scene", choices=SCENES, default="easy",
                      help="easy: no difficulty; hard: every difficulty but --misaligned, "
                           "the person's skin tone and hand size drawn from the seed")
    for name, text in (("exposure_drift", "each camera's gain wanders by up to this "
                                          "fraction over the clip"),
                       ("flicker", "and jitters by up to this fraction per frame"),
                       ("motion_blur", "fraction of the frame interval the shutter is open"),
                       ("skin_tone", "hand tone from the default (0) to the skin box's "
                                     "edges (-1, +1)"),
                       ("defocus", "blur of all but the hand, sigma per 10 px of "
                                   "disparity from it"),
                       ("hand_scale", "hand size factor")):
        lo, hi = RANGES[name]
        hard.add_argument("--" + name.replace("_", "-"), dest=name, type=float, default=None,
                          metavar="F", help=f"{text}, {lo:g}..{hi:g}")
    for name, text in (("forearm", "a bare forearm joined to the wrist, partly inside the "
                                   "band"),
                       ("clutter", "a wooden board and a second face (skin-toned, outside "
                                   "the band)"),
                       ("intruder", "a skin-coloured ball at the hand's depth rolls in and "
                                    "out"),
                       ("misaligned", "seen by the cameras of the default misaligned rig "
                                      "(sim.calibration.StereoRig; undo with its "
                                      "--calibration)")):
        hard.add_argument("--" + name, dest=name, action="store_true", default=None, help=text)


def scene_difficulties(args):
    """The --scene preset for --seed, with every difficulty option given on top."""
    import dataclasses

    from sim.difficulties import RANGES, SWITCHES, preset
    from sim.model.validation import check_int
    check_int("--seed", args.seed, 0, 2 ** 63 - 1)
    given = {name: getattr(args, name) for name in (*RANGES, *SWITCHES)
             if getattr(args, name, None) is not None}
    return dataclasses.replace(preset(args.scene, args.seed), **given)


def add_json_switch(parser, always: bool = False) -> None:
    """``--json``, the same switch on every command that prints a result: the
    result as one JSON document on the last line of stdout. ``always``: the
    command prints it anyway (the switch is accepted so that scripts can pass
    it to every command)."""
    parser.add_argument("--json", action="store_true",
                        help="the result is always printed as a JSON last line (accepted "
                             "for uniformity)" if always else
                             "also print the result as a JSON last line")


def frame_size_help(parser) -> None:
    """``--width`` and ``--height`` of a command that builds the whole pipeline,
    with the one range :meth:`sim.model.pipeline.PipelineParams.validate` enforces."""
    from sim.model.pipeline import PipelineParams
    params = PipelineParams()
    low, high = params.width_range()
    parser.add_argument("--width", type=int, default=640,
                        help=f"frame width in pixels, even, {low}..{high} with the thesis "
                             "parameters (at least D, Wc + 2, Wh + 1 and W + 2) (default: 640)")
    parser.add_argument("--height", type=int, default=480,
                        help="frame height in pixels, {}..{} (default: 480)".format(
                            *params.HEIGHT_RANGE))


def _probe(directory, path, option: str) -> None:
    """Refuse (``ValueError`` naming ``option`` and ``path``) unless a file can be
    made in ``directory``: asking the file system itself is the only answer that
    holds for a read-only mount, a pseudo file system (/proc, /sys) and root."""
    import os
    import tempfile
    try:
        fd, probe = tempfile.mkstemp(prefix=".stereogest-probe-", dir=directory)
    except OSError as exc:
        raise ValueError(f"{option}: cannot write {path} ({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(probe)


def check_output_file(path, option: str = "--output"):
    """The path of an output file, refused (``ValueError`` naming ``option``)
    before any work when its folder does not exist, cannot be written, or it is
    a directory. An existing file is replaced (atomically, by the writer)."""
    from pathlib import Path
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise ValueError(f"{option}: {path} is a directory, expected a file name")
    if not parent.is_dir():
        raise ValueError(f"{option}: directory {parent} does not exist")
    _probe(parent, path, option)
    return path


def check_output_dir(path, option: str = "--output", parents: bool = True):
    """The path of an output directory, refused before any work when it is an
    existing file, cannot be made (``parents``: the nearest existing folder
    above it must be writable; otherwise its parent must exist) or cannot be
    written."""
    from pathlib import Path
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise ValueError(f"{option}: {path} exists and is not a directory")
    if path.is_dir():
        _probe(path, path, option)
        return path
    above = path.parent if str(path.parent) else Path(".")
    if not parents and not above.is_dir():
        raise ValueError(f"{option}: directory {above} does not exist")
    while not above.exists() and above != above.parent:
        above = above.parent
    if not above.is_dir():
        raise ValueError(f"{option}: cannot create {path} ({above} is not a directory)")
    _probe(above, path, option)
    return path


def check_clip_output(path, option: str = "--output"):
    """A clip directory to be written (:func:`sim.clip.check_clip_target`: new,
    empty or an old clip), refused before any work like any output directory."""
    from sim.clip import check_clip_target
    try:
        check_clip_target(path)
    except (ValueError, FileNotFoundError) as exc:
        raise ValueError(f"{option}: {exc}") from None
    return check_output_dir(path, option, parents=False)


class OutputDir:
    """An output directory checked when this is made (:func:`check_output_dir`)
    and made when the work starts (``with OutputDir(path) as out:``); if the work
    fails a directory this made is removed again, so nothing half-written stays.
    ``stale`` globs are deleted from a reused directory first (old pictures must
    not pass for new ones)."""

    def __init__(self, path, option: str = "--output", stale=()):
        self.path, self.option, self.stale = check_output_dir(path, option), option, stale
        self.created = False

    def __enter__(self):
        if not self.path.is_dir():
            try:
                self.path.mkdir(parents=True)
            except OSError as exc:
                raise ValueError(f"{self.option}: cannot create {self.path} "
                                 f"({exc.strerror or exc})") from None
            self.created = True
        for pattern in self.stale:
            for old in self.path.glob(pattern):
                if old.is_file():
                    old.unlink()
        return self.path

    def __exit__(self, kind, value, traceback):
        if kind is not None and self.created:
            import shutil
            shutil.rmtree(self.path, ignore_errors=True)
        return False


def add_posture_option(parser) -> None:
    """``--posture``: the posture rendered gestures are made in."""
    from sim.hand_postures import COMMAND_POSTURE, POSTURE_NAMES
    parser.add_argument("--posture", default=COMMAND_POSTURE, metavar="POSTURE",
                        help="the hand's posture through a rendered gesture (default: the "
                             "shipped continuous model's command posture, "
                             f"{COMMAND_POSTURE}): " + ", ".join(POSTURE_NAMES)
                             + ", or open, point, v (asl5, asl1, asl2); drawn with the "
                             "person's proportions, a roll of up to 30 degrees and small "
                             "changes frame to frame")


def parse_sequence(text: str, posture: str, option: str = "--sequence"):
    """``NAME[@POSTURE],...`` as ``(names, postures)``, each posture resolved
    (``posture``, already resolved, where an entry names none); ``ValueError``
    names ``option`` and the entry."""
    from sim.hand_postures import resolve_posture
    names, postures = [], []
    for entry in text.split(","):
        name, at, wanted = (part.strip() for part in entry.partition("@"))
        names.append(name)
        try:
            postures.append(resolve_posture(wanted) if at else posture)
        except ValueError as exc:
            raise ValueError(f"{option}: {name}@{wanted}: {exc}") from None
    return names, postures


def resolve_posture_option(value: str, option: str = "--posture") -> str:
    """``value`` resolved to a posture name; ``ValueError`` naming ``option``."""
    from sim.hand_postures import resolve_posture
    try:
        return resolve_posture(value)
    except ValueError as exc:
        raise ValueError(f"{option}: {exc}") from None
