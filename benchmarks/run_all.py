"""Run every benchmark in this folder (``bench_*.py``) one after another and print their tables.

Not part of the test suite (timings need a quiet machine). Peers (``fringes``,
``opencv-contrib-python-headless``) are looked up in ``--peer-python`` /
``$FRINGE3D_BENCH_PYTHON`` / ``/tmp/benchvenv`` (see ``bench_decode.py``); set one up with

    python3 -m venv /tmp/benchvenv
    /tmp/benchvenv/bin/pip install fringes "opencv-contrib-python-headless==<your opencv-python-headless version>"

Example: python benchmarks/run_all.py --repeat 10
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=None, help="passed to every benchmark that takes it")
    ap.add_argument("--only", default=None, help="run only bench_NAME.py")
    args = ap.parse_args(argv)
    scripts = sorted(HERE.glob("bench_*.py"))
    if args.only:
        scripts = [s for s in scripts if s.stem in (args.only, f"bench_{args.only}")]
    failed = 0
    for script in scripts:
        print(f"== {script.name} ==", flush=True)
        cmd = [sys.executable, str(script)] + (["--repeat", str(args.repeat)] if args.repeat else [])
        t0 = time.perf_counter()
        rc = subprocess.call(cmd)
        print(f"({script.name}: exit {rc}, {time.perf_counter() - t0:.0f} s)\n", flush=True)
        failed += rc != 0
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
