"""Benchmark: the first 3D frame of a cold shell, from process start to ``points.npy`` on disk.

Run: ``.venv/bin/python benchmarks/bench_first_frame.py [--repeat 5] [--calibration demo-out/calibration.json]
[--json]`` (not a test; a quiet machine).

Once beforehand, in a temporary folder: ``fringe3d simulate --preset macro --set three-frequency-v``
(one 15-frame cycle of the demo's pattern set at 1280x1024) and ``fringe3d warmup`` (numba's
on-disk cache warm, as after ``make demo``). Then, per round, a fresh ``fringe3d reconstruct CAPTURE
-c CALIBRATION -o OUT -q`` process (a new interpreter: imports, rig, ray tables, numba's cache
loads, decoding, triangulation, writing): the time from starting it to the modification time of
``OUT/points.npy`` (the first 3D frame written) and to its exit. The calibration is the capture's
own ``rig.json`` unless ``--calibration`` names one (e.g. the demo's ``calibration.json``, the same
macro rig calibrated). Two references show what no command can go below: the bare interpreter
(``python -c pass``) and interpreter + importing the command (``import fringe3d.commands.reconstruct``).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from summary import figure  # noqa: E402  (beside this script)

GROUP = "first 3D frame of a cold shell, macro 1280x1024, three-frequency (15 frames)"


def fringe3d() -> list[str]:
    """The console script beside this interpreter (what a user types), else ``python -m fringe3d``."""
    script = Path(sys.executable).parent / "fringe3d"
    return [str(script)] if script.exists() else [sys.executable, "-m", "fringe3d"]


def run(cmd: list[str]) -> float:
    """Wall seconds of ``cmd`` (a new process); raises with its output when it fails."""
    t0 = time.time()
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stdout}{done.stderr}")
    return time.time() - t0


def first_frame(capture: Path, calibration: Path, out: Path) -> tuple[float, float]:
    """(seconds to ``out/points.npy`` written, seconds to exit) of one fresh ``fringe3d reconstruct``."""
    t0 = time.time()
    total = run([*fringe3d(), "reconstruct", str(capture), "-c", str(calibration), "-o", str(out), "-q"])
    return os.stat(out / "points.npy").st_mtime - t0, total


def main() -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="fresh processes timed")
    ap.add_argument("--calibration", type=Path, help="calibration or rig JSON of the macro rig (default: the "
                                                     "simulated capture's rig.json)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="fringe3d-first-frame-") as tmp:
        d = Path(tmp)
        cap = d / "capture"
        run([*fringe3d(), "simulate", "--preset", "macro", "--set", "three-frequency-v", "-o", str(cap), "-q"])
        run([*fringe3d(), "warmup", "-q"])
        cal = args.calibration or cap / "rig.json"
        frames, exits, bare, imports = [], [], [], []
        for k in range(args.repeat):  # the references alternate with the command (shared-machine drift)
            bare.append(run([sys.executable, "-c", "pass"]))
            imports.append(run([sys.executable, "-c", "import fringe3d.commands.reconstruct"]))
            first, total = first_frame(cap, cal, d / f"out-{k}")
            frames.append(first)
            exits.append(total)
    res = {"benchmark": "first_frame", "calibration": str(args.calibration or "capture's rig.json"),
           "figures": [figure(GROUP, "fringe3d reconstruct: start to points.npy written", "ours", "s", frames),
                       figure(GROUP, "fringe3d reconstruct: start to exit", "ours", "s", exits),
                       figure(GROUP, "python -c 'import fringe3d.commands.reconstruct'", "reference", "s",
                              imports),
                       figure(GROUP, "python -c pass (the interpreter alone)", "reference", "s", bare)]}
    if args.json:
        print(json.dumps(res))
    else:
        print(GROUP)
        for f in res["figures"]:
            print(f"  {f['name']:60s} min {f['min']:.2f}  median {f['median']:.2f}  max {f['max']:.2f} s "
                  f"({f['rounds']} runs)")
    return res


if __name__ == "__main__":
    main()
