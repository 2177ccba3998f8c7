"""`fringe3d live` end to end with a headless Chromium page open on it: 3D frames/s and latency.

Run: ``.venv/bin/python benchmarks/bench_live.py [--preset high-speed] [--seconds 20] [--step 1]
[--no-browser] [--json]`` (not a test; needs the ``live`` extra and Debian's chromium).

It runs the body of ``fringe3d live --camera virtual:PRESET --loop-cycles N --seconds S`` (the
virtual camera replaying a rendered moving take at ``--frame-rate`` Hz, 120 by default: at most
40 3-step cycles/s) with a headless Chromium page connected before the first frame, and prints the
command's own summary: 3D frames shown per second and the end-to-end latency (frame arrival to
points handed to the page) median / p95 / max, measured by the pipeline; then the page's own
figures (:mod:`fringe3d.live.page_script`, read from the page): 3D frames drawn per second and
the display latency (frame arrival to the cloud drawn in the page) median / p95 / max. Chromium
renders the cloud with software WebGL on the same cores, as a browser on the measuring machine
would.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path

from fringe3d.commands.live import LiveOptions, run_live

sys.path.insert(0, str(Path(__file__).resolve().parent))
from summary import figure  # noqa: E402  (beside this script)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="high-speed")
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--loop-cycles", type=int, default=8)
    ap.add_argument("--frame-rate", type=float, default=120.0)
    ap.add_argument("--step", type=int, default=1)
    ap.add_argument("--no-browser", action="store_true")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    served: list[str] = []
    result: dict = {}
    with tempfile.TemporaryDirectory(prefix="bench-live-") as tmp:
        o = LiveOptions(camera=f"virtual:{args.preset}", projector=None, patterns="3-step", calibration=None,
                        z_min=None, frame_rate=args.frame_rate, loop_cycles=args.loop_cycles, exposure=None,
                        frames=None, seconds=args.seconds, host="127.0.0.1", port=0, step=args.step, colour="z",
                        output=Path(tmp) / "rec", record_cycles=1, wait_viewer=0.0 if args.no_browser else 120.0,
                        hold=0.0, overwrite=False, json_=True, quiet=True)
        t = threading.Thread(target=lambda: result.update(summary=run_live(o, on_serving=served.append)))
        t.start()
        while not served and t.is_alive():
            time.sleep(0.05)
        if args.no_browser:
            t.join()
        else:
            from playwright.sync_api import sync_playwright
            chromium = shutil.which("chromium") or shutil.which("chromium-browser")
            with sync_playwright() as p:
                browser = p.chromium.launch(executable_path=chromium, args=["--headless", "--no-sandbox",
                                                                            "--disable-gpu"])
                page = browser.new_page(viewport={"width": 1280, "height": 800})
                page.goto(served[0])
                t.join()
                time.sleep(0.5)  # the last frames are drawn and the page's figures refreshed
                result["page"] = page.evaluate("() => window.fringe3dDisplay && window.fringe3dDisplay.summary")
                browser.close()
    s = result["summary"]
    s.update(browser=not args.no_browser, cores=os.cpu_count(), load_average=round(os.getloadavg()[0], 2),
             step=args.step, frame_rate=args.frame_rate)
    page = result.get("page")
    s["page"] = page
    group = (f"fringe3d live, virtual:{args.preset}, {s['size'][0]}x{s['size'][1]}, "
             f"{'headless Chromium page open' if not args.no_browser else 'no page open'}")
    s["figures"] = [figure(group, "3D frames handed to the page", "ours", "3D frames/s", [s["fps"]])] + [
        figure(group, f"latency, frame arrival to points handed to the page, {k} over the frames", "ours", "ms",
               [s["latency_ms"][k]]) for k in ("median", "p95", "max")]
    if page:
        s["figures"] += [figure(group, "3D frames drawn in the page (timed by the page)", "ours", "3D frames/s",
                                [page["fps"]])] + [
            figure(group, f"display latency, frame arrival to drawn in the page (timed by the page), {k} over "
                   "the frames", "ours", "ms", [page["latency_ms"][k]]) for k in ("median", "p95", "max")]
    if args.json:
        print(json.dumps(s, indent=1))
    else:
        lat = s["latency_ms"]
        print(f"{s['size'][0]}x{s['size'][1]} {s['path']}, step {args.step}, browser {not args.no_browser}: "
              f"{s['fps']} 3D frames/s shown ({s['frames_shown']} frames), latency median {lat['median']} ms, "
              f"p95 {lat['p95']} ms, max {lat['max']} ms; {s['cycles_skipped']} of {s['cycles_arrived']} cycles "
              f"skipped; {s['points_median']} points per frame; load average {s['load_average']} on {s['cores']} "
              "cores")
        if page:
            pl = page["latency_ms"]
            print(f"  in the page (timed by the page's script): {page['fps']} 3D frames/s drawn "
                  f"({page['frames_drawn']} frames), display latency median {pl['median']} ms, p95 {pl['p95']} ms, "
                  f"max {pl['max']} ms")


if __name__ == "__main__":
    main()
