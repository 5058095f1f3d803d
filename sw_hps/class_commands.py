"""Which robot command each class of a model file sends: the model file's
``"commands"`` object (version 5), ``{"class name": "robot command", ...}``.

The robot's commands are the thesis' seven gestures
(:data:`soc.hps_interface.GESTURE_NAMES`: each has its NXT telegram,
:mod:`sw_hps.telegram`). A model trained on one's own gestures names its
classes as one likes and maps them here (``stereogest train --commands
circle=rotate-right,...``); a class not in the object sends the command of
its own name if it has one. A class that maps to no command is refused by the
board application at start (:func:`unmapped`), since it could never move the
robot.
"""
from __future__ import annotations

from soc.hps_interface import GESTURE_NAMES

__all__ = ["check_commands", "command_of", "unmapped", "parse_commands"]


def check_commands(commands, class_names):
    """``commands`` checked against the model's ``class_names``: None, or an
    object whose keys are class names and whose values are robot commands;
    returns it as a dict (or None). ``ValueError`` names what is wrong."""
    if commands is None:
        return None
    if not isinstance(commands, dict):
        raise ValueError(f"commands must be null or an object mapping classes to robot "
                         f"commands, got {type(commands).__name__}")
    for name, command in commands.items():
        if name not in class_names:
            raise ValueError(f"commands: {name!r} is not a class of the model "
                             f"({', '.join(class_names)})")
        if command not in GESTURE_NAMES:
            raise ValueError(f"commands: class {name!r} maps to {command!r}, which is not a "
                             f"robot command ({', '.join(GESTURE_NAMES)})")
    return dict(commands)


def command_of(commands, class_name):
    """The robot command class ``class_name`` sends, or None."""
    if commands and class_name in commands:
        return commands[class_name]
    return class_name if class_name in GESTURE_NAMES else None


def unmapped(commands, class_names) -> list:
    """The classes that send no robot command."""
    return [name for name in class_names if command_of(commands, name) is None]


def parse_commands(text: str) -> dict:
    """``"circle=rotate-right,zigzag=stop"`` as a dict (command-line syntax);
    ``ValueError`` names a malformed pair."""
    pairs = {}
    for item in text.split(","):
        name, sep, command = item.partition("=")
        if not sep or not name.strip() or not command.strip():
            raise ValueError(f"--commands: {item!r} is not CLASS=COMMAND")
        pairs[name.strip()] = command.strip()
    return pairs
