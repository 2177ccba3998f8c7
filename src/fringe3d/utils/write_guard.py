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

_ROOT: contextvars.ContextVar[Path | None] = contextvars.ContextVar("fringe3d_output_root", default=None)


class OutsideOutputError(PermissionError):
    """A write that would land outside the output folder (path traversal or symlink escape)."""


def guard_write(path: str | os.PathLike) -> Path:
    """Return ``path`` resolved, or raise :class:`OutsideOutputError` when an output block is
    active and ``path`` does not resolve inside it (symlinks followed)."""
    root = _ROOT.get()
    resolved = Path(path).resolve()
    if root is not None and resolved != root and root not in resolved.parents:
        raise OutsideOutputError(f"refusing to write {path}: it resolves to {resolved}, outside the output {root}")
    return resolved


@contextmanager
def writing_into(root: str | os.PathLike) -> Iterator[Path]:
    """Activate the guard for ``root`` (a folder or a single output file) inside the block."""
    resolved = Path(root).resolve()
    token = _ROOT.set(resolved)
    try:
        yield resolved
    finally:
        _ROOT.reset(token)
