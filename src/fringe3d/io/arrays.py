"""Reading NumPy array files given by a user, with errors that name the file instead of tracebacks."""
from __future__ import annotations

import os
import zipfile
from pathlib import Path
from typing import Literal

import numpy as np


def load_array(path: str | os.PathLike, what: str = "array file",
               mmap_mode: Literal["r+", "r", "w+", "c"] | None = None):
    """``np.load(path)`` without pickles; ``ValueError`` naming ``what`` and ``path`` when the file is
    empty, truncated, not a ``.npy``/``.npz`` or holds objects; ``FileNotFoundError`` when missing."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no {what} at {path}")
    if path.stat().st_size == 0:
        raise ValueError(f"{what} {path} is empty (0 bytes); expected a NumPy .npy/.npz file")
    try:
        return np.load(path, mmap_mode=mmap_mode, allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as e:
        raise ValueError(f"{what} {path} is not a readable NumPy file ({type(e).__name__}: {e})") from None
