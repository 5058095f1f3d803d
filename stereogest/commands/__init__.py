"""One module per ``stereogest`` subcommand.

Each module defines ``NAME``, ``HELP``, ``add_arguments(parser)`` and
``run(args) -> int``; :mod:`stereogest.cli` lists them in pipeline order.
"""
