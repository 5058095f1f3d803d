"""One module per ``stereogest`` subcommand.

Each module defines ``NAME``, ``HELP``, ``add_arguments(parser)`` and
``run(args) -> int``; :mod:`stereogest.cli` lists them in pipeline order.
"""

#: The ``--seed`` every command takes by default (render, demo, gestures, train,
#: timing): one value, so a command run without it is reproducible and alike.
DEFAULT_SEED = 1


def check_output_file(path, option: str = "--output"):
    """The path of an output file, refused (``ValueError`` naming ``option``)
    before any work when its folder does not exist or it is a directory."""
    from pathlib import Path
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise ValueError(f"{option}: {path} is a directory, expected a file name")
    if not parent.is_dir():
        raise ValueError(f"{option}: directory {parent} does not exist")
    return path


class OutputDir:
    """An output directory made when the work starts (``with OutputDir(path) as
    out:``), after every option was checked: an existing file is refused, a
    directory that cannot be made is one ``ValueError`` naming ``option``, and
    if the work fails a directory this made is removed again, so nothing
    half-written stays. ``stale`` globs are deleted from a reused directory
    first (old pictures must not pass for new ones)."""

    def __init__(self, path, option: str = "--output", stale=()):
        from pathlib import Path
        self.path, self.option, self.stale = Path(path), option, stale
        if self.path.exists() and not self.path.is_dir():
            raise ValueError(f"{option}: {self.path} exists and is not a directory")
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
