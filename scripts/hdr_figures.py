"""HDR figures (issue 25): valid share and 3D RMS vs truth, one exposure vs HDR with 2 and 3.

Seeded; prints a table per scene (shiny-part, printed-part) and, with --json, the rows.
Run: PYTHONPATH=src python scripts/hdr_figures.py [--preset tiny] [--seed 0] [--json]
"""
from __future__ import annotations

import argparse
import json
import time

from fringe3d.experiments.hdr import EXPOSURES, hdr_rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--preset", default="tiny")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--gain", type=float, default=4.0)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    out = []
    for scene in ("shiny-part", "printed-part"):
        t0 = time.perf_counter()
        rows = hdr_rows(scene, a.preset, EXPOSURES, seed=a.seed, gain=a.gain)
        out += rows
        print(f"\n{scene} ({a.preset}, seed {a.seed}, {time.perf_counter() - t0:.1f} s incl. rendering)")
        print(f"{'run':28s} {'frames':>6s} {'valid':>7s} {'RMS mm':>8s} {'median mm':>9s} "
              f"{'RMS on best-single px':>22s}")
        for r in rows:
            print(f"{r['run']:28s} {r['frames']:6d} {r['valid']:7.2%} {r['rms_mm']:8.4f} {r['median_mm']:9.4f} "
                  f"{r['rms_on_best_mm']:22.4f}")
        print(f"best single exposure: {rows[0]['best_single']}")
    if a.json:
        print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
