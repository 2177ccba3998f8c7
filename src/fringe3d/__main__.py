"""The ``fringe3d`` command's entry point (also ``python -m fringe3d``).

A Ctrl-C while the command is still starting (importing its modules) exits quietly with 130;
once :func:`fringe3d.cli.main` runs, it handles Ctrl-C itself.
"""
import signal
import sys

signal.signal(signal.SIGINT, lambda signum, frame: sys.exit(130))

from fringe3d.cli import main  # noqa: E402  (after the handler: a Ctrl-C during the imports is quiet)


def run() -> None:
    """Run the command line and exit with its code."""
    sys.exit(main())


if __name__ == "__main__":
    run()
