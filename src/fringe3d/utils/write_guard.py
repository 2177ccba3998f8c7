"""The write guard: while an output block is active, every write must land inside its output.

:func:`fringe3d.utils.output_folder.open_output` activates the guard for the folder it writes;
:func:`fringe3d.utils.atomic.atomic_path` (and so every fringe3d writer) calls :func:`guard_write`
before touching the disk, so a file name taken from an input (``../../x``, an absolute path, a
symlinked sub-folder) can never make a command write elsewhere.
"""
from __future__ import annotations

import contextvars
import os
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

_ROOTS: contextvars.ContextVar[tuple[Path, ...] | None] = contextvars.ContextVar("fringe3d_output_roots",
                                                                                default=None)


class OutsideOutputError(PermissionError):
    """A write that would land outside the output folder (path traversal or symlink escape)."""


def guard_write(path: str | os.PathLike) -> Path:
    """Return ``path`` resolved, or raise :class:`OutsideOutputError` when an output block is
    active and ``path`` does not resolve inside it (symlinks followed)."""
    roots = _ROOTS.get()
    resolved = Path(path).resolve()
    if roots is not None and not any(resolved == r or r in resolved.parents for r in roots):
        shown = ", ".join(map(str, roots))
        raise OutsideOutputError(f"refusing to write {path}: it resolves to {resolved}, outside the output {shown}")
    return resolved


def is_being_written(path: str | os.PathLike) -> bool:
    """True when ``path`` is (inside) an output this process is writing right now."""
    roots = _ROOTS.get() or ()
    resolved = Path(path).resolve()
    return any(resolved == r or r in resolved.parents for r in roots)


@contextmanager
def writing_into(*roots: str | os.PathLike) -> Iterator[Path]:
    """Activate the guard for ``roots`` (output folders or single output files) inside the block;
    yields the first, resolved."""
    resolved = tuple(Path(r).resolve() for r in roots)
    token = _ROOTS.set(resolved)
    try:
        yield resolved[0]
    finally:
        _ROOTS.reset(token)
