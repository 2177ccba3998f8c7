"""Peak memory of long sequences: does it grow with the number of frames?

Run: ``.venv/bin/python benchmarks/bench_memory.py [--short 999] [--long 3999] [--json]``
(not a test). For each stage, the command runs twice in a child process, on a short and a
long take, and the child's peak resident set size (its own ``VmHWM`` at exit) is reported:

- ``reconstruct``: a 3-step + geometric sequence read from an MRAW file (``fringe3d import``
  references it), written to the zarr point store;
- ``simulate``: rendering the take itself (``fringe3d simulate``);
- ``strain``: ``fringe3d strain`` over the point store of the reconstructed take (a static plane,
  so tracking is trivial; the point is the memory).

Frames are the ``tiny`` rig's 160x128; flat memory at this size is flat at any size, since what
grows is per-frame buffers.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pyMRAW

from fringe3d.io.capture import read_capture
from fringe3d.io.store import PointMapStore
from fringe3d.patterns import sets
from fringe3d.sim import simulate_capture

sys.path.insert(0, str(Path(__file__).resolve().parent))
from summary import figure  # noqa: E402  (beside this script)

ROOT = Path(__file__).resolve().parents[1]


#: Child wrapper: run ``python -m fringe3d`` and, at exit, write the process's own high-water RSS
#: (``VmHWM``, the exec'd image's pages only) to the file named by ``$BENCH_HWM``.
_WRAP = ("import atexit, os, runpy, sys\n"
         "def _hwm():\n"
         "    line = [x for x in open('/proc/self/status') if x.startswith('VmHWM:')][0]\n"
         "    open(os.environ['BENCH_HWM'], 'w').write(line.split()[1])\n"
         "atexit.register(_hwm)\n"
         "sys.argv = ['fringe3d'] + sys.argv[1:]\n"
         "runpy.run_module('fringe3d', run_name='__main__')\n")


def peak_rss_mb(argv: list[str]) -> tuple[float, int]:
    """Run ``python -m fringe3d ARGV`` in a child; (its peak RSS in MB, its exit code).

    The peak is the child's ``VmHWM`` read by the child itself at exit, not ``ru_maxrss`` from
    ``wait4``: on Linux a child started by ``vfork`` + ``exec`` (what ``subprocess`` does) inherits
    the parent's high-water mark into ``ru_maxrss``, so this benchmark's own memory (the long
    take's frames) would leak into the figure of every child.
    """
    with tempfile.NamedTemporaryFile("r", suffix=".hwm") as hwm:
        env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "BENCH_HWM": hwm.name}
        proc = subprocess.run([sys.executable, "-c", _WRAP, *argv], env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.PIPE)
        if proc.returncode != 0:
            print(proc.stderr.decode()[-2000:], file=sys.stderr)
        text = Path(hwm.name).read_text().strip()
    return (int(text) / 1024 if text else float("nan")), proc.returncode


def anchors(store: Path) -> str:
    """Two anchor pixels on the measured surface (the wall row through the most valid pixels)."""
    P = PointMapStore.open_existing(store).read(0)
    ok = np.isfinite(P[..., 2])
    row = int(np.argmax(ok.sum(axis=1)))
    cols = np.flatnonzero(ok[row])
    return f"{cols[len(cols) // 8]},{row},{cols[-len(cols) // 8]},{row}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--short", type=int, default=999, help="frames of the short take (a multiple of 3)")
    ap.add_argument("--long", type=int, default=3999, help="frames of the long take (a multiple of 3)")
    ap.add_argument("--stages", default="reconstruct,simulate,strain",
                    help="comma-separated stages to measure; strain without reconstruct reads a store of --short / "
                         "--long copies of one reconstructed 3D frame")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    stages = set(args.stages.split(","))
    out: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        one = work / "one"
        simulate_capture(one, preset="tiny", scene="sphere", patterns=sets.phase_shift(64, 3, "v", width=256,
                                                                                        height=200),
                         seed=0, progress=False)
        cycle = read_capture(one).frames
        z_min = 340.0
        env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}

        def import_take(name: str, n: int) -> Path:
            frames = np.tile(cycle, (n // 3, 1, 1))
            mraw, _ = pyMRAW.save_mraw(frames, str(work / f"{name}.mraw"), bit_depth=8)
            cap = work / f"{name}-cap"
            subprocess.run([sys.executable, "-m", "fringe3d", "import", str(Path(mraw).with_suffix(".cih")), "-o",
                            str(cap), "--manifest", str(one / "manifest.json"), "-q"], env=env, check=True)
            return cap

        def reconstruct(cap: Path, dest: Path) -> float:
            mb, _ = peak_rss_mb(["reconstruct", str(cap), "-c", str(one / "rig.json"), "-o", str(dest), "--method",
                                 "geometric", "--z-min", str(z_min), "-q"])
            return mb

        if "strain" in stages and "reconstruct" not in stages:   # one 3D frame, repeated into the store
            reconstruct(import_take("cycle", 6), work / "cycle-3d")
            P0 = PointMapStore.open_existing(work / "cycle-3d" / "points.zarr").read(0)
        for name, n in (("short", args.short), ("long", args.long)):
            row: dict = {"frames": n}
            store = work / f"{name}-3d" / "points.zarr"
            if "reconstruct" in stages:
                row["reconstruct_mb"] = reconstruct(import_take(name, n), work / f"{name}-3d")
            elif "strain" in stages:
                st = PointMapStore.open(store, n, P0.shape[0], P0.shape[1])
                for k in range(n):
                    st.write(k, P0)
                row["strain_3d_frames"] = n
            if "simulate" in stages:
                row["simulate_mb"], _ = peak_rss_mb(["simulate", "-o", str(work / f"{name}-sim"), "--preset",
                                                     "tiny", "--scene", "sphere", "--patterns",
                                                     str(one / "manifest.json"), "--frames", str(n), "-q"])
            if "strain" in stages:
                row["strain_mb"], row["strain_exit"] = peak_rss_mb(
                    ["strain", str(store), "--anchors", anchors(store), "-o", str(work / f"{name}-strain"),
                     "--no-figures", "-q"])
            out[name] = row
    group = f"peak memory of a take, {args.short} vs {args.long} frames (tiny rig)"
    out["figures"] = [figure(group, f"{stage}, {name} take ({out[name]['frames']} frames)", "ours", "MB",
                             [out[name][stage + "_mb"]])
                      for stage in ("reconstruct", "simulate", "strain") if stage in stages
                      for name in ("short", "long")]
    if args.json:
        print(json.dumps(out, indent=1))
        return
    print(f"{'stage':12s} {'short (MB)':>12s} {'long (MB)':>12s}   frames {args.short} vs {args.long}")
    for stage in [x for x in ("reconstruct", "simulate", "strain") if x in stages]:
        print(f"{stage:12s} {out['short'][stage + '_mb']:12.1f} {out['long'][stage + '_mb']:12.1f}")


if __name__ == "__main__":
    main()
