"""Runs a command (``make test``'s pytest) with numba's compiled kernels carried over from the last
run on the *same package source*, also into a fresh clone in another folder (CI).

usage: python scripts/numba_cache.py -- COMMAND [ARG...]

numba (``cache=True``) keeps compiled kernels in ``src/fringe3d/**/__pycache__/*.nbi|*.nbc``: a
fresh clone starts with none and compiles every kernel again (minutes). This wrapper

1. computes a key: a hash of every file under ``src/fringe3d`` (path and content), of the Python,
   numba, llvmlite and NumPy versions and of the ``NUMBA_*`` settings in the environment;
2. deletes the kernels already in the tree (numba checks only a kernel's own source file, so a
   kernel compiled before a function it inlines from another file changed would be reused stale)
   and copies in the ones saved under that key, if any;
3. runs the command;
4. saves the tree's kernels as a new snapshot for the key (when the source did not change during the
   run), never rewriting one in place, and keeps the newest snapshot of the three most recently
   used keys.

Any change to any file of the package gives a new key, so a kernel is reused only with the exact
source it was compiled from. The store is ``$FRINGE3D_NUMBA_STORE`` (``off`` or empty: no store),
by default ``${XDG_CACHE_HOME:-~/.cache}/fringe3d-numba``. With ``NUMBA_CACHE_DIR`` set numba does
not use the tree and the command just runs. Exits with the command's status.
"""
from __future__ import annotations

import hashlib
import os
import platform
import shutil
import subprocess
import sys
import time
from importlib import metadata
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "fringe3d"
KEEP = 3  # keys kept in the store


def _say(message: str) -> None:
    print(f"numba_cache: {message}", file=sys.stderr, flush=True)


def store_root() -> Path | None:
    """The store folder, or None when switched off."""
    chosen = os.environ.get("FRINGE3D_NUMBA_STORE")
    if chosen is not None:
        return Path(chosen) if chosen.strip() and chosen.strip() != "off" else None
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "fringe3d-numba"


def source_key() -> str:
    """Hash of the package's files, the toolchain versions and the NUMBA_* settings."""
    h = hashlib.sha256()
    versions = [sys.version, platform.machine()] + [metadata.version(d) for d in ("numba", "llvmlite", "numpy")]
    settings = [f"{k}={v}" for k, v in sorted(os.environ.items()) if k.startswith("NUMBA_")]
    for part in versions + settings:
        h.update(part.encode() + b"\0")
    for path in sorted(p for p in PACKAGE.rglob("*") if p.is_file() and "__pycache__" not in p.parts):
        h.update(path.relative_to(PACKAGE).as_posix().encode() + b"\0")
        h.update(hashlib.sha256(path.read_bytes()).digest())
    return h.hexdigest()[:32]


def tree_kernels() -> list[Path]:
    """numba's cache files (index .nbi, object code .nbc) in the package tree."""
    return [p for p in PACKAGE.rglob("*") if p.parent.name == "__pycache__" and p.suffix in (".nbi", ".nbc")
            and p.is_file()]


def clear_tree() -> None:
    for path in tree_kernels():
        path.unlink(missing_ok=True)


def latest(store: Path, key: str) -> Path | None:
    """The newest snapshot saved for ``key`` (``store/KEY-NANOSECONDS``), if any."""
    snapshots = sorted(store.glob(f"{key}-*")) if store.is_dir() else []
    return snapshots[-1] if snapshots else None


def restore(saved: Path | None) -> int:
    """Copy the kernels of snapshot ``saved`` into the tree; the number of files copied (0 when none or
    on error). A snapshot is never changed once written, so the copy cannot mix two runs' files."""
    if saved is None:
        return 0
    n = 0
    try:
        for path in saved.rglob("*"):
            if path.is_file():
                target = PACKAGE / path.relative_to(saved)
                target.parent.mkdir(exist_ok=True)
                shutil.copyfile(path, target)
                n += 1
        os.utime(saved)  # most recently used
    except OSError as e:  # e.g. pruned by a concurrent run: start cold rather than half-restored
        _say(f"could not restore from {saved} ({e}); compiling afresh")
        clear_tree()
        return 0
    return n


def save(store: Path, key: str) -> None:
    """Write the tree's kernels as a new snapshot ``store/KEY-NANOSECONDS`` and prune the store."""
    files = tree_kernels()
    if not files:
        return
    store.mkdir(parents=True, exist_ok=True)
    tmp = store / f".{key}.{os.getpid()}.new"
    try:
        for path in files:
            target = tmp / path.relative_to(PACKAGE)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(path, target)
        tmp.rename(store / f"{key}-{time.time_ns()}")
    except OSError as e:
        _say(f"could not save to {store} ({e})")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    prune(store)


def prune(store: Path) -> None:
    """Keep the newest snapshot of each of the KEEP most recently used keys."""
    snapshots = sorted((p for p in store.iterdir() if p.is_dir() and not p.name.startswith(".")),
                       key=lambda p: p.stat().st_mtime, reverse=True)
    kept: set[str] = set()
    for path in snapshots:
        key = path.name.rsplit("-", 1)[0]
        if key in kept or len(kept) >= KEEP or path != latest(store, key):
            shutil.rmtree(path, ignore_errors=True)
        else:
            kept.add(key)
    for path in store.glob(".*"):  # a save that died half-way
        if path.stat().st_mtime < time.time() - 86400:
            shutil.rmtree(path, ignore_errors=True)


def main(argv: list[str]) -> int:
    if not argv or argv[0] != "--" or len(argv) < 2:
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        return 2
    command = argv[1:]
    store = store_root()
    if store is None or os.environ.get("NUMBA_CACHE_DIR"):
        return subprocess.call(command)
    key = source_key()
    clear_tree()
    saved = latest(store, key)
    n = restore(saved)
    _say(f"{n} files of compiled kernels restored from {saved}" if n else
         "no compiled kernels saved for this source: numba compiles them (they are saved after the run)")
    try:
        code = subprocess.call(command)
    except KeyboardInterrupt:
        return 130
    if source_key() == key:
        try:
            save(store, key)
        except OSError as e:
            _say(f"could not save to {store} ({e})")
    return code


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
