"""Render the hand postures (sim/hand_postures.py) as a DATA.npz of pictures for
'stereogest train-posture' and 'classify-posture': --people persons (seeds
--seed, --seed + 1, ...), each holding every posture still in front of the
chest; each frame goes through the golden model of the whole pipeline
(presented five frames in a row, as a hand held still in a stream), and the file
keeps the left view about the hand (image), the pipeline's posture mask
there (mask: skin AND the disparity band, opened, within the hand tracking's
window in the hard scene), the features of the frame's posture record
(features: the posture commands use them instead of the picture path), the
label (class_names: the postures) and the person (subject)."""
from __future__ import annotations

import json

from stereogest.commands import DEFAULT_SEED, add_json_switch, check_output_file

NAME = "postures"
HELP = "render hand postures through the pipeline's golden model into a DATA.npz of pictures"

_PEOPLE_RANGE = (1, 10_000)


def add_arguments(p):
    from sim.difficulties import SCENES
    from sim.hand_postures import HAND_SHAPE_NAMES
    p.add_argument("-o", "--output", metavar="DATA.npz", required=True,
                   help="file to write (replaced if it exists)")
    p.add_argument("--people", type=int, default=10,
                   help=f"persons, {_PEOPLE_RANGE[0]}..{_PEOPLE_RANGE[1]}")
    p.add_argument("--seed", type=int, default=DEFAULT_SEED,
                   help="the first person's seed (>= 0); the others follow it")
    p.add_argument("--postures", metavar="LIST", default=",".join(HAND_SHAPE_NAMES),
                   help="comma-separated postures (asl0..asl9, fist; open, point, v) and "
                        "hands that are no posture (relaxed, claw, grasp: what a hand does "
                        "between commands)")
    p.add_argument("--scene", choices=SCENES, default="easy",
                   help="hard: every difficulty, each person's skin tone and hand size, "
                        "the pipeline with hand tracking")
    p.add_argument("--width", type=int, default=640, help="frame width (even, 96..4096)")
    p.add_argument("--height", type=int, default=480, help="frame height (even, 64..4096)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    add_json_switch(p)


def run(args) -> int:
    import sys

    from recognition.datasets import save_npz
    from recognition.posture_renders import render_postures
    from sim.hand_postures import resolve_hand
    from sim.model.validation import check_int
    check_int("--people", args.people, *_PEOPLE_RANGE)
    check_int("--seed", args.seed, 0, 2 ** 63 - 1 - args.people)
    names = [n.strip() for n in args.postures.split(",")]
    try:
        names = [resolve_hand(n) for n in names]
    except ValueError as exc:
        raise ValueError(f"--postures: {exc}") from None
    if len(set(names)) != len(names):
        raise ValueError(f"--postures: each posture once, got {args.postures!r}")
    from sim.model.pipeline import PipelineParams
    PipelineParams.for_frame(args.width).validate(args.width, args.height)
    output = check_output_file(args.output)

    def progress(done, total):
        if not args.quiet:
            print(f"  person {done}/{total}", file=sys.stderr, flush=True)
    arrays = render_postures(names, range(args.seed, args.seed + args.people),
                             width=args.width, height=args.height, scene=args.scene,
                             progress=progress)
    save_npz(output, arrays)
    report = {"output": str(output), "pictures": int(len(arrays["label"])),
              "people": args.people, "postures": names, "scene": args.scene}
    print(f"{report['pictures']} pictures of {len(names)} postures by {args.people} people "
          f"({args.scene} scene) written to {output}")
    if args.json:
        print(json.dumps(report))
    return 0
