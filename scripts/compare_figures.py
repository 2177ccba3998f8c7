"""Behaviour check for refactors: every figure of two revisions, compared key by key.

Runs ``fringe3d demo --seed 0 --json`` and ``fringe3d experiment NAME --quick --json`` for every
experiment, once per revision (each checked out into a temporary git worktree, run with that
tree's ``src/`` first on ``PYTHONPATH``), or reads the JSON files a previous run saved
(``--save DIR`` / ``--load-a DIR``). Wall-clock fields (keys naming seconds, time, wall, speed or
frames per second) are dropped; everything else must be equal. Prints one line per output and
every differing value. Calibrations are not bit-deterministic from run to run (threaded
reductions in OpenCV's solvers move figures by ~1e-8 relative), so compare those with
``--rtol 1e-6`` and say so.

Example: python scripts/compare_figures.py 6d45a32 HEAD --save /tmp/figs
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
CLOCK = re.compile(r"(second|seconds|time|wall|per_s|/s\b|fps|elapsed|duration|\(s\)|_s$)", re.I)


def _runs(tree: Path, out: Path) -> dict[str, Path]:
    """Run the demo and every quick experiment from ``tree``; their JSON files in ``out``."""
    env = dict(os.environ, PYTHONPATH=str(tree / "src"))
    cli = [sys.executable, "-c", "import sys; from fringe3d.cli import main; sys.exit(main(sys.argv[1:]))"]
    listing = subprocess.run(cli + ["experiment", "--list", "--json"], env=env, capture_output=True, text=True)
    try:
        names = json.loads(listing.stdout)
    except json.JSONDecodeError:  # older revisions print a table for --list --json
        names = []
    if isinstance(names, dict):
        names = names.get("experiments", list(names))
    names = [n["name"] if isinstance(n, dict) else n for n in names] or [
        "binary-defocus", "defocus-calibration", "falling-balls", "flapping-wing", "motion-error",
        "optimal-angle", "single-shot", "telecentric", "unwrap-noise"]
    jobs = {"demo": ["demo", "--seed", "0", "-o", str(out / "demo-out"), "--json"]}
    jobs.update({f"exp-{n}": ["experiment", n, "--quick", "--json"] for n in names})
    out.mkdir(parents=True, exist_ok=True)
    files = {}
    for key, args in jobs.items():
        res = subprocess.run(cli + args, env=env, cwd=out, capture_output=True, text=True)
        files[key] = out / f"{key}.json"
        files[key].write_text(res.stdout if res.returncode == 0 else json.dumps({"exit": res.returncode}))
    return files


def _strip(obj):
    if isinstance(obj, dict) and isinstance(obj.get("columns"), list) and isinstance(obj.get("rows"), list):
        keep = [i for i, c in enumerate(obj["columns"]) if not CLOCK.search(str(c)) and str(c) != "time ms"]
        obj = dict(obj, columns=[obj["columns"][i] for i in keep],
                   rows=[[r[i] for i in keep] if isinstance(r, list) else r for r in obj["rows"]])
    if isinstance(obj, dict):
        return {k: _strip(v) for k, v in obj.items() if not CLOCK.search(str(k))}
    if isinstance(obj, list):
        return [_strip(v) for v in obj]
    return obj


def _diff(a, b, path="", rtol=0.0) -> list[str]:
    """Differences between two JSON values; floats may differ by ``rtol`` (relative)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = [f"{path}/{k}: only in {'A' if k in a else 'B'}" for k in sorted(set(a) ^ set(b))]
        for k in sorted(set(a) & set(b)):
            out += _diff(a[k], b[k], f"{path}/{k}", rtol)
        return out
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in _diff(x, y, f"{path}[{i}]", rtol)]
    if isinstance(a, float) and isinstance(b, float) and abs(a - b) <= rtol * max(abs(a), abs(b)):
        return []
    return [] if a == b else [f"{path}: A {a!r} != B {b!r}"]


def _tree(rev: str, tmp: Path, label: str) -> Path:
    tree = tmp / label  # by side, not by revision: A and B may name the same commit (a determinism check)
    subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", "-q", str(tree), rev], check=True)
    return tree


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rev_a")
    ap.add_argument("rev_b")
    ap.add_argument("--load-a", type=Path, help="use the JSON files saved by an earlier run for A")
    ap.add_argument("--save", type=Path, help="keep the JSON files here (A/ and B/)")
    ap.add_argument("--rtol", type=float, default=0.0,
                    help="relative tolerance for floats (default 0: bit-identical)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="fringe3d-figs-") as tmp_name:
        tmp = Path(tmp_name)
        save = args.save or tmp / "out"
        trees = []
        try:
            if args.load_a:
                fa = {p.stem: p for p in args.load_a.glob("*.json")}
            else:
                trees.append(_tree(args.rev_a, tmp, "A"))
                fa = _runs(trees[-1], save / "A")
            trees.append(_tree(args.rev_b, tmp, "B"))
            fb = _runs(trees[-1], save / "B")
        finally:
            for tree in trees:
                subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(tree)], check=False)
        failed = 0
        for key in sorted(set(fa) | set(fb)):
            if key not in fa or key not in fb:
                print(f"{key}: only in {'A' if key in fa else 'B'}")
                failed += 1
                continue
            d = _diff(_strip(json.loads(fa[key].read_text())), _strip(json.loads(fb[key].read_text())), rtol=args.rtol)
            print(f"{key}: {'identical' if not d else f'{len(d)} differences'}")
            for line in d[:20]:
                print(f"    {line}")
            failed += bool(d)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
