"""Run every benchmark in this folder (``bench_*.py``) with ``--json`` and print ONE summary table.

Not part of the test suite (timings need a quiet machine). Each benchmark reports its figures
(``benchmarks/summary.py``): min / median / max over alternated rounds, grouped with the copy
bound and the fused kernel timed in the same rounds and with the peers where there are any. The
table gives every figure its ratio to the kernel and to the bound and its speed-up over the
fastest installed peer, and every benchmarked scene its wrap-error count.

Peers (``fringes``, ``opencv-contrib-python-headless``) run in the interpreter named by
``--peer-python`` / ``$FRINGE3D_BENCH_PYTHON`` / ``/tmp/benchvenv`` (see ``bench_decode.py``;
``make bench`` sets up ``.venv-bench``); where none has them, their rows read "peer not
installed". A benchmark whose prerequisite is missing (``bench_cuda.py`` without a CUDA device,
``bench_live.py`` without the ``live`` extra) is skipped and listed; headless Chromium missing,
``bench_live.py`` runs with no page open. The exit status is 0 unless a benchmark that ran failed.

Every benchmark's JSON and log go to ``--out`` (default: a new temporary folder, printed).

Example: python benchmarks/run_all.py --repeat 10
         python benchmarks/run_all.py --quick --repeat 2   (smaller inputs: a check of the harness)
"""
from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from summary import format_table, table_rows  # noqa: E402  (beside this script)

#: arguments of --quick: smaller inputs, the same code paths (figures not comparable with a full run)
QUICK = {"bench_decode_scaling": ["--sizes", "512x640,1024x1280"],
         "bench_sequence": ["--cycles", "12", "--rounds", "1"], "bench_memory": ["--short", "99", "--long", "399"],
         "bench_multiview": ["--views", "4"],
         "bench_live": ["--seconds", "5"], "bench_strain": ["--frames", "3"], "bench_evaluate": ["--size", "400"]}


def takes(script: Path, option: str) -> bool:
    """Whether ``script`` has the command-line option ``option`` (not every benchmark has each)."""
    return re.search(rf"add_argument\(\s*[\"']{re.escape(option)}[\"']", script.read_text()) is not None


def takes_repeat(script: Path) -> bool:
    """Whether ``script`` has a ``--repeat`` option."""
    return takes(script, "--repeat")


def probe(code: str) -> bool:
    """Whether ``code`` runs without error in this interpreter (a child process)."""
    return subprocess.call([sys.executable, "-c", code], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL) == 0


def cuda_device_present() -> bool:
    """Whether numba sees a physical CUDA device (``bench_cuda.py`` needs one; the simulator does
    not count)."""
    return probe("from numba import cuda; import sys; sys.exit(0 if cuda.is_available() else 1)")


def command(script: Path, repeat: int | None, out_dir: Path, quick: bool = False) -> tuple[list[str] | None, str]:
    """The command line that runs ``script`` with JSON output, and a note; None and the reason
    when a prerequisite is missing."""
    cmd = [sys.executable, str(script)]
    note = ""
    if repeat and takes_repeat(script):
        cmd += ["--repeat", str(repeat)]
    if quick:
        cmd += QUICK.get(script.stem, [])
    if script.stem == "bench_cuda":
        if not cuda_device_present():
            return None, "no CUDA device (run it on a GPU machine, see docs/gpu.md)"
        return cmd + ["--out", str(out_dir / "bench_cuda.out.json"), "--overwrite"], note
    if script.stem == "bench_live":
        if not probe("import viser"):
            return None, "the live extra is not installed (pip install -e '.[live]')"
        if not (shutil.which("chromium") or shutil.which("chromium-browser")) or not probe("import playwright"):
            cmd.append("--no-browser")
            note = "no headless Chromium: run with no page open"
    if takes(script, "--json"):
        cmd.append("--json")
    return cmd, note


def parse_json(stdout: str) -> dict | None:
    """The JSON object a benchmark printed (the first object starting a line), or None."""
    dec = json.JSONDecoder()
    for m in re.finditer(r"^[{\[]", stdout, re.M):
        try:
            obj, _ = dec.raw_decode(stdout[m.start():])
        except json.JSONDecodeError:
            continue
        return obj if isinstance(obj, dict) else {"rows": obj}
    return None


def collect(results: dict[str, dict]) -> tuple[list[dict], dict]:
    """All figures and group notes of the benchmarks' JSON objects, in run order."""
    figures: list[dict] = []
    groups: dict = {}
    for data in results.values():
        figures += data.get("figures", [])
        groups.update(data.get("groups", {}))
    return figures, groups


def summary(results: dict[str, dict], status: dict[str, str], header: str) -> str:
    """The one summary table and the list of benchmarks that were skipped, failed or gave no figures."""
    figures, groups = collect(results)
    lines = [format_table(table_rows(figures), groups, header)]
    notes = [f"  {name}: {s}" for name, s in status.items() if s != "ok"]
    if notes:
        lines += ["", "not in the table:" if any("skipped" in n or "failed" in n for n in notes) else "notes:", *notes]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=None, help="rounds, passed to every benchmark that takes it")
    ap.add_argument("--only", default=None, help="comma-separated benchmarks to run (NAME or bench_NAME)")
    ap.add_argument("--skip", default=None, help="comma-separated benchmarks not to run")
    ap.add_argument("--quick", action="store_true", help="smaller inputs (a check of the harness, not figures)")
    ap.add_argument("--out", default=None, help="folder for each benchmark's JSON and log (default: a new temporary "
                    "one); not written into when it holds files, unless --overwrite")
    ap.add_argument("--overwrite", action="store_true", help="replace the files of an existing --out folder")
    args = ap.parse_args(argv)
    if args.out and Path(args.out).is_dir() and any(Path(args.out).iterdir()) and not args.overwrite:
        ap.error(f"--out {args.out}: the folder holds files; pass --overwrite to replace them")

    def names(csv: str | None) -> set[str]:
        return {n if n.startswith("bench_") else f"bench_{n}" for n in (csv or "").split(",") if n}
    scripts = sorted(HERE.glob("bench_*.py"))
    if args.only:
        scripts = [s for s in scripts if s.stem in names(args.only)]
    scripts = [s for s in scripts if s.stem not in names(args.skip)]
    out_dir = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="fringe3d-bench-"))
    out_dir.mkdir(parents=True, exist_ok=True)
    load0, t_all = os.getloadavg()[0], time.perf_counter()
    results: dict[str, dict] = {}
    status: dict[str, str] = {}
    failed = 0
    for script in scripts:
        cmd, note = command(script, args.repeat, out_dir, args.quick)
        if cmd is None:
            status[script.name] = f"skipped: {note}"
            print(f"{script.name}: skipped, {note}", flush=True)
            continue
        print(f"{script.name}: running{' (' + note + ')' if note else ''} ...", end=" ", flush=True)
        t0 = time.perf_counter()
        log = out_dir / f"{script.stem}.log"
        with open(log, "w") as err:
            proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=err, text=True)
        dt = time.perf_counter() - t0
        data = (parse_json(proc.stdout) if script.stem != "bench_cuda" else
                json.loads((out_dir / "bench_cuda.out.json").read_text()) if proc.returncode == 0 else None)
        if data is not None:
            (out_dir / f"{script.stem}.json").write_text(json.dumps(data, indent=1))
            results[script.name] = data
        if proc.returncode != 0:
            failed += 1
            status[script.name] = f"failed (exit {proc.returncode}), log {log}"
        elif data is None or not data.get("figures"):
            status[script.name] = f"ran, no summary figures (output in {out_dir})"
        else:
            status[script.name] = "ok" if not note else f"ok, {note}"
        print(f"exit {proc.returncode}, {dt:.0f} s", flush=True)
    try:
        import numba
        threads = numba.config.NUMBA_NUM_THREADS
    except ImportError:
        threads = "?"
    header = (f"fringe3d benchmarks: {os.cpu_count()} cores, numba threads {threads}, load average "
              f"{load0:.1f} -> {os.getloadavg()[0]:.1f}, {time.perf_counter() - t_all:.0f} s"
              f"{', --quick' if args.quick else ''}{f', --repeat {args.repeat}' if args.repeat else ''}; "
              f"JSON and logs in {out_dir}\n"
              "x kernel / x bound: median time / the fused kernel's / the copy bound's, same run, same rounds "
              "(rates as 1/rate); peer: the fastest installed peer's median time / this figure's")
    print("\n" + summary(results, status, header), flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
