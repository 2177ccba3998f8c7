"""Two ``fringe3d reconstruct`` output folders compared byte for byte: every file of their point
stores (``points.zarr``: chunks, ``zarr.json``, coordinates) and PLY folders (``ply/``).

Run: ``python benchmarks/compare_outputs.py A B`` (not a test). For an A/B of two source trees:
reconstruct the same capture into A with one tree first on ``PYTHONPATH`` and into B with the
other (same command, same options), then compare. A PLY header quotes the command line, whose
``-o`` names the output folder: each folder's own path is replaced by ``OUT`` in its PLY files
before comparing, nothing else. Prints the files compared and those that differ; exit status 1
when a file differs or is in one folder only.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path


def output_files(root: Path) -> dict[Path, Path]:
    """The store's and the PLY folder's files under ``root``, by path relative to it."""
    return {p.relative_to(root): p for p in sorted(root.rglob("*"))
            if p.is_file() and ("points.zarr" in p.parts or "ply" in p.parts)}


def file_bytes(root: Path, path: Path) -> bytes:
    """The bytes of ``path``; in a PLY file the first quote of ``root`` (the command's ``-o``) as ``OUT``."""
    data = path.read_bytes()
    return data.replace(str(root.resolve()).encode(), b"OUT", 1) if path.suffix == ".ply" else data


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a", type=Path)
    ap.add_argument("b", type=Path)
    args = ap.parse_args()
    fa, fb = output_files(args.a), output_files(args.b)
    only = sorted(set(fa) ^ set(fb))
    differ = [k for k in sorted(set(fa) & set(fb)) if file_bytes(args.a, fa[k]) != file_bytes(args.b, fb[k])]
    for k in only:
        print(f"in one folder only: {k}")
    for k in differ:
        print(f"differs: {k}")
    print(f"{len(set(fa) & set(fb))} files compared, {len(differ)} differ, {len(only)} in one folder only")
    return 1 if differ or only else 0


if __name__ == "__main__":
    sys.exit(main())
