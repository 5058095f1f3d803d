"""Giving up root once the bridge is mapped (``python -m sw_hps --user NAME``).

Runs on the board's ARM: Python 3.7 and the standard library, nothing else.

Of everything the board application does, only opening ``/dev/mem`` and mapping
the bridge's page needs root (``CAP_SYS_RAWIO``); with ``--bus uio`` nothing
does. ``--user NAME`` lets a service started as root (the ``--bus devmem``
drop-in of ``stereogest.service``, the SysV init script) run the rest as the
dedicated user ``install.sh --service`` creates: the bus is opened and mapped
first, then the process takes NAME's user, primary group and supplementary
groups (the robot's tty through ``dialout``), so the HMMs, the robot link and
every reload of the model file run without root. A mapping made before the
switch stays usable, as the kernel checks permissions when it is made.
"""
from __future__ import annotations

import grp
import os
import pwd

__all__ = ["PrivilegeError", "look_up_user", "drop_privileges"]


class PrivilegeError(Exception):
    """The switch to the user cannot be made; one line naming ``--user``."""


def look_up_user(name: str):
    """The password entry of ``name``; ``PrivilegeError`` if there is none."""
    try:
        return pwd.getpwnam(name)
    except KeyError:
        raise PrivilegeError(f"argument --user: no user {name!r} on this system "
                             f"(install.sh --service creates 'stereogest')") from None


def drop_privileges(name: str, readable=()) -> bool:
    """Run as user ``name`` from now on, for good.

    Parameters
    ----------
    name : str
        The user; its primary group and the groups listing it become the process'.
    readable : iterable of str
        Files and directories the application reads later (its package for
        imports, the model files for SIGHUP reloads): checked after the switch,
        so that a directory the user cannot enter fails now, in one line,
        rather than at the first reload.

    Returns
    -------
    bool
        True if the identity changed, False if the process already runs as
        ``name`` (nothing to do).

    Raises
    ------
    PrivilegeError
        No such user, not root, the switch refused, root still reachable
        afterwards, or a path in ``readable`` the user cannot read.
    """
    entry = look_up_user(name)
    if os.getuid() == entry.pw_uid and os.geteuid() == entry.pw_uid:
        return False
    if os.geteuid() != 0:
        raise PrivilegeError(f"argument --user: switching to {name!r} needs root "
                             f"(this process runs as uid {os.geteuid()}); leave --user out")
    groups = sorted(set(os.getgrouplist(name, entry.pw_gid)))
    try:
        os.setgroups(groups)
        os.setgid(entry.pw_gid)     # the group first: without root it cannot change
        os.setuid(entry.pw_uid)
    except OSError as exc:
        raise PrivilegeError(f"argument --user: cannot switch to {name!r}: {exc.strerror}"
                             ) from None
    try:                            # setuid must have been for good
        os.setuid(0)
    except OSError:
        pass
    else:
        raise PrivilegeError(f"argument --user: root is still reachable after switching "
                             f"to {name!r}")
    for path in readable:
        mode = os.R_OK | (os.X_OK if os.path.isdir(path) else 0)
        if not os.access(path, mode):
            group = grp.getgrgid(entry.pw_gid).gr_name
            raise PrivilegeError(
                f"argument --user: {name!r} cannot read {path}: install the application "
                f"where {name}:{group} can read it (e.g. /opt/stereogest), or leave --user out")
    return True
