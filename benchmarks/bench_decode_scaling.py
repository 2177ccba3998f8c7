"""decode() against the memory-copy bound at three sizes: is its cost linear in pixels?

For each size (640x512, 1280x1024, 2560x2048 by default) the 15-frame three-frequency and the
3-step captures of ``bench_decode.py`` (seed 0) are decoded with every default output, and the
copy bound of the same frames (``np.copyto``) is timed in the same alternated rounds; medians in ms,
ns per pixel, and the ratio to the bound. Run it once per source tree to compare revisions, e.g.
``PYTHONPATH=src python benchmarks/bench_decode_scaling.py --json``.

Example: python benchmarks/bench_decode_scaling.py --sizes 512x640,1024x1280 --repeat 5
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_decode as bd  # noqa: E402
from summary import alternated, stats, timed_figures  # noqa: E402

from fringe3d.decode import decode  # noqa: E402


def measure(height: int, width: int, repeat: int) -> tuple[dict, list[dict]]:
    """Median ms of decode() and of the copy bound for both captures at one size (alternated
    rounds), and the same as summary figures."""
    bd.H, bd.W = height, width
    ps15, f15, ps3, f3, _ = bd.make_frames()
    row: dict = {"size": f"{width}x{height}"}
    figs: list[dict] = []
    for name, frames, ps in (("decode15", f15, ps15), ("decode3", f3, ps3)):
        sec = alternated({"bound": bd.bound_cases(frames)["bound"],
                          "decode": lambda f=frames, p=ps: decode(f, p)}, repeat)
        ms, bound = (1000 * stats(sec[k])["median"] for k in ("decode", "bound"))
        row[name] = {"ms": round(ms, 1), "ns_per_px": round(1e6 * ms / (height * width), 1),
                     "bound_ms": round(bound, 2), "x_bound": round(ms / bound, 2)}
        group = f"decode scaling, {'15-frame' if name == 'decode15' else '3-step'}, {width}x{height}"
        figs += timed_figures(group, sec, {"bound": "bound", "decode": "ours"},
                              names={"bound": "copy bound: np.copyto of the frames", "decode": "decode()"})
    return row, figs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="512x640,1024x1280,2048x2560", help="HxW list")
    ap.add_argument("--repeat", type=int, default=7, help="alternated rounds (median reported)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    measured = [measure(*map(int, s.split("x")), args.repeat) for s in args.sizes.split(",")]
    rows = [m[0] for m in measured]
    if args.json:
        print(json.dumps({"benchmark": "decode_scaling", "rows": rows,
                          "figures": [f for m in measured for f in m[1]]}))
        return 0
    for r in rows:
        for name in ("decode15", "decode3"):
            m = r[name]
            print(f"{r['size']:>10} {name}: {m['ms']:8.1f} ms  {m['ns_per_px']:6.1f} ns/px  "
                  f"bound {m['bound_ms']:7.2f} ms  {m['x_bound']:5.2f}x bound")
    return 0


if __name__ == "__main__":
    sys.exit(main())
