"""Console output shared by the sub-commands: rich tables, progress bars, JSON, quiet mode.

Progress bars and ``info`` are off unless the command layer enabled them (``set_quiet(False)``),
so a library call never draws on the terminal.
"""
from __future__ import annotations

import json
import math
from contextlib import contextmanager
from typing import Iterable, Iterator

from rich.console import Console
from rich.progress import (
    BarColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.markup import escape
from rich.table import Table

from fringe3d.utils.jsonfile import to_jsonable

console = Console()
err_console = Console(stderr=True, soft_wrap=True)  # messages and paths stay on one line


class _Settings:
    # Library functions are silent by default; the CLI turns output on (``fringe3d.cli.main``)
    # and each sub-command's quiet and JSON options turn it off again.
    quiet: bool = True
    #: (description, done, total) of the innermost progress bar, kept even when quiet, so an
    #: interrupted command can say how far it got.
    progress: tuple[str, int, int | None] | None = None


settings = _Settings()


def set_quiet(quiet: bool) -> None:
    """Silence progress bars and informational output (tables still print unless JSON output was asked for)."""
    settings.quiet = quiet


@contextmanager
def progress_bar(description: str, total: int | None, enabled: bool = True) -> Iterator:
    """A rich progress bar on stderr; yields ``advance(n=1)``. Disabled when quiet; the count is
    kept in ``settings.progress`` either way."""
    settings.progress = (description, 0, total)

    def count(n: int = 1) -> None:
        d, done, tot = settings.progress or (description, 0, total)
        settings.progress = (d, done + n, tot)

    if settings.quiet or not enabled:
        yield count
        return
    prog = Progress(TextColumn("[bold]{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                    TimeElapsedColumn(), TimeRemainingColumn(), console=err_console, transient=True)
    with prog:
        task = prog.add_task(description, total=total)

        def advance(n: int = 1) -> None:
            count(n)
            prog.advance(task, n)
        yield advance


def track(items: Iterable, description: str, total: int | None = None) -> Iterator:
    """Iterate with a progress bar (on stderr, silenced by :func:`set_quiet`)."""
    if total is None:
        items = list(items)
        total = len(items)
    with progress_bar(description, total) as advance:
        for it in items:
            yield it
            advance()


def info(msg: str) -> None:
    if not settings.quiet:
        err_console.print(msg)


def warn(msg: str) -> None:
    """``warning: msg`` on stderr; ``msg`` is shown literally (``[...]`` is not rich markup)."""
    err_console.print(f"[yellow]warning:[/] {escape(msg)}")




def print_json(obj) -> None:
    """Print one JSON object on stdout (a command's machine-readable output)."""
    print(json.dumps(to_jsonable(obj), indent=1))


def make_table(title: str, columns: list[str], rows: list[list]) -> Table:
    t = Table(title=title, title_justify="left")
    for c in columns:
        # fold, never truncate: a narrow terminal wraps a long cell instead of printing "direct…"
        t.add_column(str(c), justify="right" if c not in columns[:1] else "left", overflow="fold")
    for r in rows:
        t.add_row(*[_fmt(v) for v in r])
    return t


def _fmt(v) -> str:
    import numpy as np  # here, not at the top: the command line's start (``--help``) needs no numpy

    if isinstance(v, (float, np.floating)):
        if not math.isfinite(v):
            return "—"
        a = abs(float(v))
        if a != 0 and (a < 1e-3 or a >= 1e5):
            return f"{v:.3g}"
        return f"{v:.4g}"
    return str(v)
