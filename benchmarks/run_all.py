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
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def takes_repeat(script: Path) -> bool:
    """Whether ``script`` has a ``--repeat`` option (not every benchmark does)."""
    return re.search(r"add_argument\(\s*[\"']--repeat[\"']", script.read_text()) is not None


def cuda_device_present() -> bool:
    """Whether numba sees a physical CUDA device (``bench_cuda.py`` needs one; the simulator does
    not count)."""
    probe = "from numba import cuda; import sys; sys.exit(0 if cuda.is_available() else 1)"
    return subprocess.call([sys.executable, "-c", probe], stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL) == 0


def command(script: Path, repeat: int | None, out_dir: Path) -> list[str] | None:
    """The command line that runs ``script``; None for the GPU benchmark where there is no GPU."""
    cmd = [sys.executable, str(script)]
    if repeat and takes_repeat(script):
        cmd += ["--repeat", str(repeat)]
    if script.stem == "bench_cuda":
        if not cuda_device_present():
            return None
        cmd += ["--out", str(out_dir / "cuda.json"), "--overwrite"]
    return cmd


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=None, help="passed to every benchmark that takes it")
    ap.add_argument("--only", default=None, help="run only bench_NAME.py")
    args = ap.parse_args(argv)
    scripts = sorted(HERE.glob("bench_*.py"))
    if args.only:
        scripts = [s for s in scripts if s.stem in (args.only, f"bench_{args.only}")]
    failed = 0
    out_dir = Path(tempfile.mkdtemp(prefix="fringe3d-bench-"))
    for script in scripts:
        print(f"== {script.name} ==", flush=True)
        cmd = command(script, args.repeat, out_dir)
        if cmd is None:
            print(f"({script.name}: skipped, no CUDA device; run it on a GPU machine, see docs/gpu.md)\n", flush=True)
            continue
        t0 = time.perf_counter()
        rc = subprocess.call(cmd)
        print(f"({script.name}: exit {rc}, {time.perf_counter() - t0:.0f} s)\n", flush=True)
        failed += rc != 0
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
