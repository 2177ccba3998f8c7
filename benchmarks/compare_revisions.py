"""Side-by-side speed of two revisions: decode and reconstruct benchmarks, interleaved in one run.

Each revision is checked out into a temporary git worktree and its own ``bench_decode.py`` and
``bench_reconstruct.py`` run with that worktree's ``src/`` first on ``PYTHONPATH`` (same
interpreter, same machine, alternating A, B, B, A ... so that drift hits both). Prints, per
benchmark figure, the median over the rounds for each revision and the ratio B / A.

Not part of the test suite (timings need a quiet machine).

Example: python benchmarks/compare_revisions.py 6d45a32 HEAD --rounds 3
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
BENCHES = {"decode": ["--no-peers", "--json", "--repeat", "10"], "reconstruct": ["--json", "--repeat", "30"]}


def _flatten(obj, prefix=""):
    """``{"a": {"b": 1.0}}`` -> ``{"a.b": 1.0}`` (numbers only)."""
    out = {}
    if isinstance(obj, dict):
        for k, v in obj.items():
            out.update(_flatten(v, f"{prefix}{k}."))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            out.update(_flatten(v, f"{prefix}{i}."))
    elif isinstance(obj, (int, float)) and not isinstance(obj, bool):
        out[prefix[:-1]] = float(obj)
    return out


def _run(tree: Path, bench: str) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree / "src"))
    cmd = [sys.executable, str(tree / "benchmarks" / f"bench_{bench}.py"), *BENCHES[bench]]
    out = subprocess.run(cmd, env=env, cwd=tree, capture_output=True, text=True, check=True).stdout
    return _flatten(json.loads(out))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rev_a", help="baseline revision (e.g. a commit or tag)")
    ap.add_argument("rev_b", help="revision to compare (e.g. HEAD)")
    ap.add_argument("--rounds", type=int, default=3, help="alternating rounds per revision")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="fringe3d-revs-") as tmp:
        trees = {}
        for key, rev in (("a", args.rev_a), ("b", args.rev_b)):
            trees[key] = Path(tmp) / key
            subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", "-q", str(trees[key]), rev],
                           check=True)
        try:
            runs = {(b, k): [] for b in BENCHES for k in trees}
            for r in range(args.rounds):
                for bench in BENCHES:
                    for key in (("a", "b") if r % 2 == 0 else ("b", "a")):  # ABBA: drift hits both
                        runs[bench, key].append(_run(trees[key], bench))
        finally:
            for tree in trees.values():
                subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(tree)], check=False)
    rows = []
    for bench in BENCHES:
        keys = sorted(set(runs[bench, "a"][0]) & set(runs[bench, "b"][0]))
        for name in keys:
            if not any(w in name for w in ("ms", "per_s", "_s")):
                continue
            a = statistics.median(r[name] for r in runs[bench, "a"])
            b = statistics.median(r[name] for r in runs[bench, "b"])
            rows.append({"bench": bench, "figure": name, "a": a, "b": b, "ratio_b_over_a": b / a if a else None})
    if args.json:
        print(json.dumps({"rev_a": args.rev_a, "rev_b": args.rev_b, "rounds": args.rounds, "rows": rows}, indent=1))
    else:
        print(f"A = {args.rev_a}, B = {args.rev_b}, median of {args.rounds} alternating rounds")
        for r in rows:
            ratio = f"{r['ratio_b_over_a']:.3f}" if r["ratio_b_over_a"] is not None else "-"
            print(f"  {r['bench']:11s} {r['figure']:42s} A {r['a']:10.4g}  B {r['b']:10.4g}  B/A {ratio}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
