"""Side-by-side speed of two revisions: decode and reconstruct benchmarks, interleaved in one run.

Each revision is checked out into a temporary git worktree; this checkout's ``bench_decode.py``
and ``bench_reconstruct.py`` (the same benchmark code for both, so that only the library
differs) run with that worktree's ``src/`` first on ``PYTHONPATH`` (same interpreter, same
machine, in ABBA order: A B, B A, A B, ... so that drift hits both). Prints, per benchmark figure
(``benchmarks/summary.py``), the median over the rounds for each revision and the ratio B / A.

``--fail-above 1.2`` makes the exit status 1 when a figure of fringe3d's own code (roles
``ours`` and ``kernel``; not the copy bound or other references, which measure the machine)
regresses by more than 20 %: a time whose B / A exceeds 1.2, or a rate whose B / A falls below
1 / 1.2. ``make bench-check`` runs it on HEAD against the last release (see the Makefile).

Not part of the test suite (timings need a quiet machine). A baseline too old for today's
benchmark scripts fails with the script's error (exit 2).

Example: python benchmarks/compare_revisions.py 6d45a32 HEAD --rounds 3 --fail-above 1.2
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))
from summary import compare_figures, figure_key, regressions  # noqa: E402  (beside this script)

BENCHES = {"decode": ["--no-peers", "--json", "--repeat", "10"], "reconstruct": ["--json", "--repeat", "30"]}
#: roles whose regression fails --fail-above (the others measure the machine or benchmark code)
GATED_ROLES = ("ours", "kernel")


def failing(rows: list[dict], fail_above: float | None) -> list[dict]:
    """The rows of ``summary.compare_figures`` (with their ``role``) that fail ``--fail-above``:
    regressions of fringe3d's own figures (:data:`GATED_ROLES`); none without a threshold."""
    if fail_above is None:
        return []
    return regressions([r for r in rows if r.get("role") in GATED_ROLES], fail_above)


def _run(tree: Path, bench: str, repeat: int | None) -> dict[str, tuple[float, str]]:
    """{figure key: (median, role)} of one run of this checkout's ``bench_BENCH.py`` on ``tree``'s library."""
    env = dict(os.environ, PYTHONPATH=str(tree / "src"))
    args = list(BENCHES[bench])
    if repeat:
        args[args.index("--repeat") + 1] = str(repeat)
    cmd = [sys.executable, str(HERE / f"bench_{bench}.py"), *args]
    proc = subprocess.run(cmd, env=env, cwd=tree, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"bench_{bench}.py on {tree} failed (exit {proc.returncode}): "
                           f"{(proc.stderr or '').strip().splitlines()[-1:]}")
    figs = json.loads(proc.stdout)["figures"]
    return {figure_key(f): (f["median"], f["role"]) for f in figs if f.get("median") is not None}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rev_a", help="baseline revision (e.g. a commit or tag)")
    ap.add_argument("rev_b", help="revision to compare (e.g. HEAD)")
    ap.add_argument("--rounds", type=int, default=3, help="ABBA rounds per revision (each runs every benchmark)")
    ap.add_argument("--repeat", type=int, default=None, help="alternated rounds inside each benchmark run "
                    "(default: decode 10, reconstruct 30)")
    ap.add_argument("--fail-above", type=float, default=None,
                    help="exit 1 when a figure of fringe3d's code regresses by more than this ratio (1.2: 20 %%)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    if args.fail_above is not None and not args.fail_above > 1.0:
        ap.error(f"--fail-above {args.fail_above}: expected a ratio above 1 (1.2 fails on a 20 % regression)")
    runs: dict[str, dict[str, list[float]]] = {"a": {}, "b": {}}
    roles: dict[str, str] = {}
    with tempfile.TemporaryDirectory(prefix="fringe3d-revs-") as tmp:
        trees = {}
        for key, rev in (("a", args.rev_a), ("b", args.rev_b)):
            trees[key] = Path(tmp) / key
            subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", "-q", str(trees[key]), rev],
                           check=True)
        try:
            for r in range(args.rounds):
                for bench in BENCHES:
                    for key in (("a", "b") if r % 2 == 0 else ("b", "a")):  # ABBA: drift hits both
                        for name, (median, role) in _run(trees[key], bench, args.repeat).items():
                            runs[key].setdefault(name, []).append(median)
                            roles[name] = role
        except RuntimeError as e:
            print(f"compare_revisions: {e}", file=sys.stderr)
            return 2
        finally:
            for tree in trees.values():
                subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(tree)], check=False)
    rows = compare_figures(runs["a"], runs["b"])
    for row in rows:
        row["role"] = roles.get(row["figure"], "")
    bad = failing(rows, args.fail_above)
    if args.json:
        print(json.dumps({"rev_a": args.rev_a, "rev_b": args.rev_b, "rounds": args.rounds, "rows": rows,
                          "fail_above": args.fail_above, "regressions": bad}, indent=1))
    else:
        print(f"A = {args.rev_a}, B = {args.rev_b}, median of {args.rounds} ABBA rounds "
              f"(B / A > 1 is slower for a time, faster for a rate)")
        for r in rows:
            ratio = f"{r['ratio_b_over_a']:.3f}" if r["ratio_b_over_a"] is not None else "-"
            flag = "  REGRESSION" if r in bad else ""
            print(f"  {r['figure']:100s} A {r['a']:10.4g}  B {r['b']:10.4g}  B/A {ratio}{flag}")
        if args.fail_above:
            print(f"{len(bad)} figure(s) of fringe3d's code regressed by more than "
                  f"{100 * (args.fail_above - 1):.0f} %" + (": " + "; ".join(r["figure"] for r in bad) if bad else ""))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
