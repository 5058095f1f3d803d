"""Set the posture commands of a gesture model file (its ``postures`` entry,
sw_hps.posture_commands): the command postures a gesture must be made in
(--command, with --share of its frames), the stop posture that stops the
robot when held for --stop-frames records (--stop), the clutch (--release-frames
records in a row out of a command posture end any gesture, --neutral postures
counting neither way), and the motor power each
command posture puts in the NXT telegram (--power: POSTURE=P pairs, or
``fingers``: 20 per extended finger). --clear removes the entry. Every
posture must be a class of the posture model (--posture-model, default the
shipped one); the file is rewritten whole or not at all, and not at all when
no option changes it (``--table`` alone prints)."""
from __future__ import annotations

from stereogest.commands import add_json_switch

NAME = "posture-commands"
HELP = "set a model file's command and stop postures and the power of each command posture"

#: Motor power per extended finger with ``--power fingers``.
POWER_PER_FINGER = 20


def add_arguments(p):
    p.add_argument("model", metavar="MODEL.json", help="gesture model file to change in place")
    # dest: "command" is the subcommand's name
    p.add_argument("--command", dest="command_postures", metavar="LIST", default=None,
                   help="comma-separated postures a gesture must be made in (e.g. asl2,asl3); "
                        "'none': every gesture commands")
    p.add_argument("--share", type=float, default=None, metavar="S",
                   help="share of a gesture's frames that must be in a command posture "
                        "(0..1, default 0.5)")
    p.add_argument("--stop", metavar="POSTURE", default=None,
                   help="posture that stops the robot at once (e.g. fist); 'none': no stop")
    p.add_argument("--stop-frames", type=int, default=None, metavar="N",
                   help="posture records in a row that stop (1..30, default 3)")
    p.add_argument("--release-frames", type=int, default=None, metavar="N",
                   help="posture records in a row out of a command posture that end any "
                        "gesture in progress (0..30; 0, the default: none, the share only)")
    p.add_argument("--neutral", metavar="LIST", default=None,
                   help="comma-separated postures that neither hold nor release the clutch "
                        "(ones the classifier names a moving command posture by mistake); "
                        "'none': every other posture releases it")
    p.add_argument("--power", metavar="P", default=None,
                   help="motor power of each command posture: POSTURE=P,... (0..100), "
                        f"'fingers' ({POWER_PER_FINGER} per extended finger) or 'none'")
    p.add_argument("--posture-model", metavar="POSTURE.json", default=None,
                   help="posture classifier whose classes the postures must be "
                        "(default: the one shipped in sw_hps/models)")
    p.add_argument("--clear", action="store_true", help="remove the postures entry")
    p.add_argument("--table", action="store_true",
                   help="print the commands the model knows (every gesture class in every "
                        "command posture, with its power and telegram) as a Markdown table")
    add_json_switch(p)


def _power(text: str, command: list) -> dict | None:
    if text == "none":
        return None
    if text == "fingers":
        from sim.hand_postures import POSTURE_NAMES, extended_fingers
        unknown = [n for n in command if n not in POSTURE_NAMES]
        if unknown:
            raise ValueError(f"--power fingers: {', '.join(unknown)} has no known finger count")
        return {name: POWER_PER_FINGER * extended_fingers(name) for name in command}
    power = {}
    for item in text.split(","):
        name, eq, level = item.strip().partition("=")
        try:
            power[name.strip()] = int(level)
        except ValueError:
            raise ValueError(f"--power: expected POSTURE=P pairs, 'fingers' or 'none', "
                             f"got {item.strip()!r}") from None
        if not eq or not name.strip():
            raise ValueError(f"--power: expected POSTURE=P pairs, got {item.strip()!r}")
    return power


def _option(message: str) -> str:
    """The option a message about a key of the postures entry is about."""
    for key in ("stop_frames", "release_frames", "command", "share", "stop", "neutral",
                "power"):
        if message.startswith(f"postures {key}"):
            return "--" + key.replace("_", "-")
    return "--command/--stop/--neutral/--power"


def run(args) -> int:
    import json

    from stereogest.pipeline_outputs import load_posture_model
    from sw_hps.hmm import load_models, save_models
    from sw_hps.posture_commands import check_posture_classes, check_posture_commands

    models = load_models(args.model)
    posture_model = load_posture_model(args.posture_model)
    changed = [v for v in (args.command_postures, args.share, args.stop, args.stop_frames,
                           args.release_frames, args.neutral, args.power) if v is not None]
    if args.clear:
        if changed:
            raise ValueError("--clear takes no other posture option")
        entry = None
    else:
        entry = dict(models.postures or {})
        if args.command_postures is not None:
            entry["command"] = [] if args.command_postures == "none" else \
                [n.strip() for n in args.command_postures.split(",")]
        if args.share is not None:
            entry["share"] = args.share
        if args.stop is not None:
            entry["stop"] = None if args.stop == "none" else args.stop
        if args.stop_frames is not None:
            entry["stop_frames"] = args.stop_frames
        if args.release_frames is not None:
            entry["release_frames"] = args.release_frames
        if args.neutral is not None:
            entry["neutral"] = [] if args.neutral == "none" else \
                [n.strip() for n in args.neutral.split(",")]
        if args.power is not None:
            entry["power"] = _power(args.power, entry.get("command", []))
        try:
            entry = check_posture_commands(entry)
            check_posture_classes(entry, posture_model.class_names, where="postures")
        except ValueError as exc:
            raise ValueError(f"{_option(str(exc))}: {exc}") from None
    if args.clear or changed:  # only printing (--table alone) leaves the file as it is
        import dataclasses
        save_models(dataclasses.replace(models, postures=entry, meta=dict(models.meta)),
                    args.model)
    if entry is None:
        print(f"{args.model}: no posture commands")
    else:
        power = entry["power"]
        print(f"{args.model}: commands in {', '.join(entry['command']) or 'any posture'}"
              f" (at least {100 * entry['share']:.0f} % of a gesture's frames)"
              + (f", stop in {entry['stop']} held {entry['stop_frames']} records"
                 if entry["stop"] else ", no stop posture")
              + (f", released by {entry['release_frames']} records out of them"
                 + (f" ({', '.join(entry['neutral'])} neutral)" if entry["neutral"] else "")
                 if entry["release_frames"] else "")
              + (", power " + ", ".join(f"{k} {v}" for k, v in power.items()) if power
                 else ""))
    if args.table:
        print(command_table(models.class_names, entry))
    if args.json:
        print(json.dumps({"model": str(args.model), "postures": entry}))
    return 0


def command_table(class_names, entry) -> str:
    """Every gesture class in every command posture: the robot's action, the
    power and the NXT telegram, as a Markdown table; then the stop posture's."""
    from sw_hps.telegram import GESTURE_NAMES, ROBOT_ACTIONS, telegram
    postures = (entry or {}).get("command") or [None]
    power = (entry or {}).get("power") or {}
    lines = ["| gesture | posture | robot action | power | telegram |", "|---|---|---|---|---|"]
    for name in class_names:
        for posture in postures:
            level = power.get(posture)
            if name in GESTURE_NAMES:
                action = ROBOT_ACTIONS[GESTURE_NAMES.index(name)]
                code = telegram(name, power=level).hex(" ")
            else:
                action, code = "none (not a robot gesture)", "-"
            lines.append(f"| {name} | {posture or 'any'} | {action} | "
                         f"{'-' if level is None else level} | `{code}` |")
    if entry is not None and entry["stop"] is not None:
        lines.append(f"| (held {entry['stop_frames']} frames) | {entry['stop']} | "
                     f"{ROBOT_ACTIONS[GESTURE_NAMES.index('stop')]} | - | "
                     f"`{telegram('stop').hex(' ')}` |")
    return "\n".join(lines)
