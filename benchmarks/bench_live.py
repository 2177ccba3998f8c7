"""`fringe3d live` end to end with a headless Chromium page open on it: 3D frames/s and latency.

Run: ``.venv/bin/python benchmarks/bench_live.py [--preset high-speed] [--seconds 20] [--step 1]
[--show depth|cloud] [--viewport 1280x800] [--no-browser] [--json]`` (not a test; needs the
``live`` extra and Debian's chromium).

It runs the body of ``fringe3d live --camera virtual:PRESET --loop-cycles N --seconds S`` (the
virtual camera replaying a rendered moving take at ``--frame-rate`` Hz, 120 by default: at most
40 3-step cycles/s) with a headless Chromium page connected before the first frame, and prints the
command's own summary: 3D frames shown per second and the end-to-end latency (frame arrival to
points handed to the page) median / p95 / max, measured by the pipeline; then the page's own
figures (:mod:`fringe3d.live.page_script`, read from the page): 3D frames drawn per second and
the display latency (frame arrival to the depth image or the cloud, ``--show``, drawn in the
page) median / p95 / max; then the ratio of frames drawn to frames handed to the page, the CPU
time Chromium's processes spent per frame drawn (from /proc, by process type: renderer,
gpu-process, browser, ...; from the page's load to the run's end), this process's CPU time per
frame handed to the page (the pipeline and viser), and the page's main-thread time per frame
drawn (CDP Performance.getMetrics: tasks, script, layout, style; wall time, which load
stretches). Chromium renders the cloud with software WebGL on the same cores, as a
browser on the measuring machine would; before the run it times the same browser drawing a bare
WebGL page (:data:`BARE_WEBGL`) at the same viewport: the ceiling of any page there.
"""
from __future__ import annotations

import argparse
import contextlib
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


#: A bare WebGL page as large as the viewport, drawing 20 000 points each animation frame into a
#: canvas set up as viser's (antialias, preserveDrawingBuffer): the most frames/s this browser can
#: draw here, whatever a live view sends it.
BARE_WEBGL = """<body style="margin:0"><canvas id=c></canvas><script>
const c = document.getElementById('c'); c.width = innerWidth; c.height = innerHeight;
const gl = c.getContext('webgl2', {antialias: true, preserveDrawingBuffer: true});
const sh = (t, s) => { const x = gl.createShader(t); gl.shaderSource(x, s); gl.compileShader(x); return x; };
const pr = gl.createProgram();
gl.attachShader(pr, sh(gl.VERTEX_SHADER, `#version 300 es
in vec3 p; void main() { gl_Position = vec4(p, 1.0); gl_PointSize = 4.0; }`));
gl.attachShader(pr, sh(gl.FRAGMENT_SHADER, `#version 300 es
precision mediump float; out vec4 o; void main() { o = vec4(1.0, 0.5, 0.2, 1.0); }`));
gl.linkProgram(pr); gl.useProgram(pr);
const d = new Float32Array(60000).map(() => Math.random() * 1.6 - 0.8);
gl.bindBuffer(gl.ARRAY_BUFFER, gl.createBuffer()); gl.bufferData(gl.ARRAY_BUFFER, d, gl.DYNAMIC_DRAW);
gl.enableVertexAttribArray(0); gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 0, 0);
window.drawn = 0;
const loop = () => { gl.clearColor(1, 1, 1, 1); gl.clear(gl.COLOR_BUFFER_BIT); gl.bufferSubData(gl.ARRAY_BUFFER, 0, d);
  gl.drawArrays(gl.POINTS, 0, 20000); window.drawn++; requestAnimationFrame(loop); };
requestAnimationFrame(loop);
</script></body>"""


def _children() -> dict[int, list[int]]:
    kids: dict[int, list[int]] = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                ppid = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            kids.setdefault(ppid, []).append(int(d.name))
    return kids


def chromium_cpu() -> dict[tuple[int, str], float]:
    """CPU seconds (user + system) of each Chromium process descended from this one, by (pid, its
    ``--type``: renderer, gpu-process, ..., or browser) (Linux /proc)."""
    kids, out, todo = _children(), {}, [os.getpid()]
    while todo:
        for pid in kids.get(todo.pop(), []):
            todo.append(pid)
            try:
                stat = Path(f"/proc/{pid}/stat").read_text()
            except OSError:
                continue
            name, fields = stat[stat.index("(") + 1:stat.rindex(")")], stat.rsplit(")", 1)[1].split()
            if "chrom" in name.lower():
                try:
                    args = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").split()
                except OSError:
                    continue
                kind = next((a[7:].decode() for a in args if a.startswith(b"--type=")), "browser")
                out[(pid, kind)] = (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    return out


def cpu_between(before: dict, after: dict) -> dict[str, float]:
    """CPU seconds the processes used between two :func:`chromium_cpu` readings, by process type
    (those that ended in between are not counted)."""
    out: dict[str, float] = {}
    for key, t in after.items():
        out[key[1]] = out.get(key[1], 0.0) + t - before.get(key, 0.0)
    return out


def main_thread(cdp) -> dict[str, float]:
    """Seconds the page's main thread has spent so far: in tasks, script, layout and style (CDP's
    Performance.getMetrics)."""
    m = {x["name"]: x["value"] for x in cdp.send("Performance.getMetrics")["metrics"]}
    return {k: m[k] for k in ("TaskDuration", "ScriptDuration", "LayoutDuration", "RecalcStyleDuration")}


def webgl_ceiling(browser, viewport: dict, seconds: float = 3.0) -> float:
    """Frames/s the browser draws a bare WebGL page at this viewport (:data:`BARE_WEBGL`)."""
    page = browser.new_page(viewport=viewport)
    page.set_content(BARE_WEBGL)
    time.sleep(1.0)
    n0, t0 = page.evaluate("window.drawn"), time.monotonic()
    time.sleep(seconds)
    n1, t1 = page.evaluate("window.drawn"), time.monotonic()
    page.close()
    return round((n1 - n0) / (t1 - t0), 1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="high-speed")
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--loop-cycles", type=int, default=8)
    ap.add_argument("--frame-rate", type=float, default=120.0)
    ap.add_argument("--step", type=int, default=1)
    ap.add_argument("--show", default="depth", choices=("cloud", "depth"), help="the view the page shows")
    ap.add_argument("--no-browser", action="store_true")
    ap.add_argument("--viewport", default="1280x800", help="the page's size, WIDTHxHEIGHT")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    served: list[str] = []
    result: dict = {}
    viewport = dict(zip(("width", "height"), (int(v) for v in args.viewport.split("x"))))
    with tempfile.TemporaryDirectory(prefix="bench-live-") as tmp, contextlib.ExitStack() as stack:
        page = None
        if not args.no_browser:
            from playwright.sync_api import sync_playwright
            chromium = shutil.which("chromium") or shutil.which("chromium-browser")
            p = stack.enter_context(sync_playwright())
            browser = p.chromium.launch(executable_path=chromium, args=["--headless", "--no-sandbox", "--disable-gpu"])
            stack.callback(browser.close)
            result["webgl_ceiling"] = webgl_ceiling(browser, viewport)
            page = browser.new_page(viewport=viewport)
        o = LiveOptions(camera=f"virtual:{args.preset}", projector=None, patterns="3-step", calibration=None,
                        z_min=None, frame_rate=args.frame_rate, loop_cycles=args.loop_cycles, exposure=None,
                        frames=None, seconds=args.seconds, host="127.0.0.1", port=0, step=args.step, colour="z",
                        show=args.show,
                        output=Path(tmp) / "rec", record_cycles=1, wait_viewer=0.0 if args.no_browser else 120.0,
                        hold=0.0, overwrite=False, json_=True, quiet=True)
        t = threading.Thread(target=lambda: result.update(summary=run_live(o, on_serving=served.append)))
        t.start()
        while not served and t.is_alive():
            time.sleep(0.05)
        cdp = metrics0 = None
        if page is not None:
            page.goto(served[0])
            cdp = page.context.new_cdp_session(page)  # the page's main thread: what its time went to
            cdp.send("Performance.enable")
            metrics0 = main_thread(cdp)
        cpu0, own0 = chromium_cpu(), os.times()
        t.join()
        cpu1, own1 = chromium_cpu(), os.times()
        if cdp is not None:
            result["main_thread_s"] = {k: v - metrics0[k] for k, v in main_thread(cdp).items()}
        result["chromium_cpu_s"] = cpu_between(cpu0, cpu1)
        result["python_cpu_s"] = own1.user + own1.system - own0.user - own0.system
        if page is not None:
            time.sleep(0.5)  # the last frames are drawn and the page's figures refreshed
            result["page"] = page.evaluate("() => window.fringe3dDisplay && window.fringe3dDisplay.summary")
    s = result["summary"]
    s.update(browser=not args.no_browser, cores=os.cpu_count(), load_average=round(os.getloadavg()[0], 2),
             step=args.step, show=args.show, frame_rate=args.frame_rate, viewport=args.viewport,
             webgl_ceiling_fps=result.get("webgl_ceiling"))
    page = result.get("page")
    s["page"] = page
    # CPU per frame: the process running the pipeline and viser (per frame handed to the page), Chromium's
    # processes (per frame drawn in the page); from the page's load to the run's end
    s["python_cpu_ms_per_frame"] = round(1e3 * result["python_cpu_s"] / max(s["frames_shown"], 1), 1)
    drawn = max(page["frames_drawn"], 1) if page else 1
    s["chromium_cpu_ms_per_drawn_frame"] = (round(1e3 * sum(result["chromium_cpu_s"].values()) / drawn, 1)
                                            if page else None)
    s["chromium_cpu_ms_per_drawn_frame_by_process"] = {k: round(1e3 * v / drawn, 1)
                                                       for k, v in result["chromium_cpu_s"].items()}
    s["page_main_thread_ms_per_drawn_frame"] = {k: round(1e3 * v / drawn, 1)
                                                for k, v in result.get("main_thread_s", {}).items()}
    group = (f"fringe3d live, virtual:{args.preset}, {s['size'][0]}x{s['size'][1]}, {args.show} view, "
             f"{'headless Chromium page open' if not args.no_browser else 'no page open'}")
    s["figures"] = [figure(group, "3D frames handed to the page", "ours", "3D frames/s", [s["fps"]])] + [
        figure(group, f"latency, frame arrival to points handed to the page, {k} over the frames", "ours", "ms",
               [s["latency_ms"][k]]) for k in ("median", "p95", "max")]
    if page:
        s["figures"] += [figure(group, "3D frames drawn in the page (timed by the page)", "ours", "3D frames/s",
                                [page["fps"]])] + [
            figure(group, f"display latency, frame arrival to drawn in the page (timed by the page), {k} over "
                   "the frames", "ours", "ms", [page["latency_ms"][k]]) for k in ("median", "p95", "max")]
        s["figures"].append(figure(group, "Chromium's CPU time (all its processes) per 3D frame drawn in the page",
                                   "ours", "ms", [s["chromium_cpu_ms_per_drawn_frame"]]))
    if s["webgl_ceiling_fps"] is not None:
        s["figures"].append(figure(group, f"bare WebGL page drawn by this browser at {args.viewport}", "reference",
                                   "frames/s", [s["webgl_ceiling_fps"]]))
    if args.json:
        print(json.dumps(s, indent=1))
    else:
        lat = s["latency_ms"]
        print(f"{s['size'][0]}x{s['size'][1]} {s['path']}, {args.show} view, step {args.step}, "
              f"browser {not args.no_browser}: "
              f"{s['fps']} 3D frames/s shown ({s['frames_shown']} frames), latency median {lat['median']} ms, "
              f"p95 {lat['p95']} ms, max {lat['max']} ms; {s['cycles_skipped']} of {s['cycles_arrived']} cycles "
              f"skipped; {s['points_median']} points per frame; load average {s['load_average']} on {s['cores']} "
              "cores")
        if page:
            pl = page["latency_ms"]
            print(f"  in the page (timed by the page's script): {page['fps']} 3D frames/s drawn "
                  f"({page['frames_drawn']} frames), display latency median {pl['median']} ms, p95 {pl['p95']} ms, "
                  f"max {pl['max']} ms; this browser draws a bare WebGL page at {args.viewport} at "
                  f"{s['webgl_ceiling_fps']} frames/s")
            print(f"  drawn / handed to the page: {page['fps'] / max(s['fps'], 1e-9):.2f}; CPU per frame: "
                  f"Chromium {s['chromium_cpu_ms_per_drawn_frame']} ms per drawn frame "
                  f"({s['chromium_cpu_ms_per_drawn_frame_by_process']}), this process "
                  f"{s['python_cpu_ms_per_frame']} ms (per frame handed to the page); the page's main thread "
                  f"per drawn frame (ms): {s['page_main_thread_ms_per_drawn_frame']}")


if __name__ == "__main__":
    main()
