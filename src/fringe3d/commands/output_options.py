"""Options every writing command shares: ``--overwrite`` and ``--allow-empty``."""
from __future__ import annotations

import typer

OVERWRITE_HELP = ("Replace an existing output. The new one is written beside it and swapped in only once "
                  "complete, so an interrupted run leaves the old one untouched.")
ALLOW_EMPTY_HELP = "Exit 0 even when no pixel is valid (the outputs are written; default: exit 2 saying why)."


def overwrite_option() -> bool:
    """``--overwrite`` (a typer option default)."""
    return typer.Option(False, "--overwrite", help=OVERWRITE_HELP)


def allow_empty_option() -> bool:
    """``--allow-empty`` (a typer option default)."""
    return typer.Option(False, "--allow-empty", help=ALLOW_EMPTY_HELP)
