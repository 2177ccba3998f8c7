"""`fringe3d live` in a real headless browser: the page receives the engine's points and shows the
pipeline's own figures.

One run of the command's body (``run_live``, in a thread of this process: the kernels and the
simulator are loaded once; the virtual camera replays a rendered moving take on the tiny rig) is
watched by headless Chromium. The bytes the browser's websocket received are decoded (viser's
wire format: zstd-compressed msgpack plus raw aligned buffers) into the point clouds the page
drew, and the figures are read from the page's own GUI fields. Truths: the same take rendered in
the test and reconstructed by :class:`fringe3d.reconstruct.frame.FrameReconstructor` (each cloud
sent equals one of the loop's cycles exactly), the simulator's ground truth (those points lie on
the scene within the tiny rig's accuracy), and the command's --json summary (the page shows the
same figures). A second run shows the depth view (``--show depth``): the page receives no cloud and
one message per frame, the frame's stamp with its JPEG depth image inline; the images decode to the
colour ramp's colours of the engine's depths, the page draws them in its own canvas over the hidden
3D view, and it times the images it drew against the stamps they came with.
"""
from __future__ import annotations

import json
import re
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from headless_chromium import launch

from fringe3d.commands.live import LiveOptions, run_live
from fringe3d.decode import DecodeOptions
from fringe3d.live.display import BAR_ROWS, display_points
from fringe3d.live.page_script import ARRIVAL_ATTRIBUTE, DEPTH_CANVAS_ID, FIGURES_ID, FRAME_ATTRIBUTE
from fringe3d.live.viewer import LABELS
from fringe3d.reconstruct.frame import FrameReconstructor, reconstruction_plans
from fringe3d.sim.live_take import render_take
from fringe3d.utils.warning_types import DepthRangeWarning

LOOP_CYCLES = 4
FRAME_RATE = 120.0
FRAMES = 12

#: JavaScript: the value of the GUI input in the row whose label reads `label`.
GUI_VALUE = """label => {
  const el = [...document.querySelectorAll('label, p, span, div')].filter(e => e.textContent.trim() === label).pop();
  let row = el;
  while (row && !row.querySelector('input')) row = row.parentElement;
  return row ? row.querySelector('input').value : null;
}"""


def _messages(payload: bytes) -> list[dict]:
    """viser's wire format: [u64 msgpack size][u64 compressed size][zstd msgpack][aligned buffers];
    each array is a ``{"__binary_index": i, "dtype": ...}`` placeholder into the buffers."""
    import msgspec
    import zstandard

    inner_size = int.from_bytes(payload[:8], "little")
    csize = int.from_bytes(payload[8:16], "little")
    body = msgspec.msgpack.decode(zstandard.ZstdDecompressor().decompress(payload[16:16 + csize],
                                                                          max_output_size=inner_size))
    buffers, offset = [], 16 + csize
    for n in body["binaryBufferLengths"]:
        offset += (8 - offset % 8) % 8
        buffers.append(payload[offset:offset + n])
        offset += n

    def resolve(v):
        if isinstance(v, dict) and "__binary_index" in v:
            return np.frombuffer(buffers[v["__binary_index"]], dtype=np.dtype(v["dtype"]))
        if isinstance(v, dict):
            return {k: resolve(x) for k, x in v.items()}
        if isinstance(v, list):
            return [resolve(x) for x in v]
        return v

    return [resolve(m) for m in body["messages"]]


def _clouds(messages: list[dict]) -> list[np.ndarray]:
    """The point clouds among decoded messages: the first as a new scene node, the next as updates of
    its points."""
    return ([m["props"]["points"].reshape(-1, 3) for m in messages if m.get("type") == "PointCloudMessage"] +
            [m["updates"]["points"].reshape(-1, 3) for m in messages
             if m.get("type") == "SceneNodeUpdateMessage" and "points" in m.get("updates", {})])


def _options(record: Path, show: str = "cloud") -> LiveOptions:
    return LiveOptions(camera="virtual:tiny", projector=None, patterns="3-step", calibration=None, z_min=None,
                       frame_rate=FRAME_RATE, loop_cycles=LOOP_CYCLES, exposure=None, frames=FRAMES, seconds=None,
                       host="127.0.0.1", port=0, step=1, colour="z", show=show, output=record, record_cycles=1,
                       wait_viewer=60.0, hold=2.0, overwrite=False, json_=True, quiet=True)


@pytest.fixture(scope="module")
def live_run(tmp_path_factory):
    """Run `fringe3d live` for FRAMES 3D frames with a headless Chromium page open on it."""
    return _watch(tmp_path_factory.mktemp("live"), "cloud")


@pytest.fixture(scope="module")
def depth_run(tmp_path_factory):
    """As :func:`live_run`, in the depth view."""
    return _watch(tmp_path_factory.mktemp("live-depth"), "depth")


def _watch(out: Path, show: str) -> dict:
    """Run `fringe3d live --show SHOW` for FRAMES 3D frames with a headless Chromium page open on it."""
    from playwright.sync_api import sync_playwright

    served: list[str] = []
    result: dict = {}

    def run() -> None:
        try:
            result["summary"] = run_live(_options(out / "rec", show), on_serving=served.append)
        except BaseException as e:  # handed to the test
            result["error"] = e

    live = threading.Thread(target=run, daemon=True)
    received: list[bytes] = []
    t_start = time.time()
    with sync_playwright() as p:
        browser = launch(p)
        live.start()
        end = time.monotonic() + 60
        while not served and live.is_alive() and time.monotonic() < end:
            time.sleep(0.05)
        assert served, f"fringe3d live did not serve its page: {result.get('error')!r}"
        page = browser.new_page(viewport={"width": 1000, "height": 700})
        page.on("websocket", lambda ws: ws.on("framereceived",
                                              lambda data: received.append(data) if isinstance(data, bytes) else None))
        page.goto(served[0])
        page.wait_for_function(f"() => ({GUI_VALUE})({json.dumps(LABELS['frames_shown'])}) === '{FRAMES}'",
                               timeout=60_000, polling=100)
        time.sleep(0.3)  # the final figures follow the last frame
        shown = {key: page.evaluate(GUI_VALUE, LABELS[key]) for key in LABELS}
        # the page's own timing: its figures cover the last frame (always drawn: nothing newer replaces it)
        page.wait_for_function(f"() => window.fringe3dDisplay && window.fringe3dDisplay.summary && "
                               f"window.fringe3dDisplay.summary.last_frame === {FRAMES}", timeout=30_000, polling=100)
        timed = page.evaluate("() => { const d = window.fringe3dDisplay; return {frame: d.frame, arrival: d.arrival, "
                              "received: d.received, drawn: d.drawn, tick: d.tick, latency: d.latency}; }")
        timed["shown"] = page.evaluate(f"() => document.getElementById('{FIGURES_ID}').textContent")
        timed["depth_canvas"] = page.evaluate(f"""() => {{ const c = document.getElementById('{DEPTH_CANVAS_ID}');
            const gl = [...document.querySelectorAll('canvas')].find(x => x !== c);
            return c ? {{width: c.width, height: c.height, position: getComputedStyle(c).position,
                        shown: getComputedStyle(c).display !== 'none',
                        view_hidden: !!gl && getComputedStyle(gl).display === 'none'}} : null; }}""")
        page.screenshot(path=str(out / "live.png"))
        browser.close()
    live.join(timeout=60)
    assert "error" not in result, result.get("error")
    return {"summary": result["summary"], "shown": shown, "received": received, "out": out, "timed": timed,
            "wall": (t_start * 1e3, time.time() * 1e3)}


@pytest.fixture(scope="module")
def loop_points():
    """The loop's cycles reconstructed by the engine, as the page draws them, with their truth."""
    take = render_take("tiny", "3-step", LOOP_CYCLES, FRAME_RATE, seed=0)
    rec = FrameReconstructor(reconstruction_plans(take.patterns, take.method), take.preset.rig,
                             DecodeOptions(z_min=take.z_min, bit_depth=8))
    n = len(take.patterns)
    out = []
    for k in range(LOOP_CYCLES):
        with warnings.catch_warnings():  # the ball's silhouette wraps a few pixel pairs: noted, as in the live run
            warnings.simplefilter("ignore", DepthRangeWarning)
            cyc = rec.reconstruct(take.frames[k * n:(k + 1) * n], uncertainty=False, texture=False)
        pts, _ = display_points(cyc.points, None, "z", (300.0, 500.0))
        mid = k * n + n // 2  # the truth at the cycle's middle frame
        valid = np.isfinite(cyc.points[..., 2])
        out.append((pts, cyc.points[valid], take.truth.xyz[mid][valid], take.truth.mask[mid][valid],
                    (cyc.points, cyc.quality)))
    return out


@pytest.mark.browser
@pytest.mark.parametrize("run", ["live_run", "depth_run"])
def test_live_page_shows_the_figures_the_pipeline_measured(run, request):
    s, shown = request.getfixturevalue(run)["summary"], request.getfixturevalue(run)["shown"]
    assert s["frames_shown"] == FRAMES and shown["frames_shown"] == str(FRAMES)
    assert float(shown["fps"]) == pytest.approx(s["fps"], abs=0.051)
    assert float(shown["latency_median"]) == pytest.approx(s["latency_ms"]["median"], abs=0.051)
    assert float(shown["latency_p95"]) == pytest.approx(s["latency_ms"]["p95"], abs=0.051)
    assert int(shown["points"]) == s["points_median"] > 0
    assert s["path"] == "fused 3-step + geometric kernel" and s["size"] == [160, 128]


@pytest.mark.browser
def test_live_page_receives_exactly_the_points_the_engine_reconstructs(live_run, loop_points):
    clouds = [c for payload in live_run["received"] for c in _clouds(_messages(payload))]
    assert clouds, "the page received no point cloud"
    for cloud in clouds:
        matches = [k for k, (pts, *_) in enumerate(loop_points) if pts.shape == cloud.shape and
                   np.array_equal(pts, cloud)]
        assert len(matches) == 1, "a cloud the page received is not one of the loop's cycles as the engine made it"


def _stamps(payloads: list[bytes]) -> list[tuple[int, float, bool]]:
    """(frame, arrival ms, a point cloud in the same websocket message) of each frame stamp the page received."""
    out = []
    for payload in payloads:
        messages = _messages(payload)
        cloud = bool(_clouds(messages))
        for m in messages:
            content = m.get("updates", {}).get("content", "") if m.get("type") == "GuiUpdateMessage" else ""
            if FRAME_ATTRIBUTE in content:
                frame = int(re.search(f'{FRAME_ATTRIBUTE}="([0-9]+)"', content).group(1))
                arrival = float(re.search(f'{ARRIVAL_ATTRIBUTE}="([0-9.]+)"', content).group(1))
                out.append((frame, arrival, cloud))
    return out


@pytest.mark.browser
def test_live_frame_stamps_travel_with_their_point_clouds(live_run):
    stamps = _stamps(live_run["received"])
    clouds = sum(len(_clouds(_messages(p))) for p in live_run["received"])
    unstamped = sum(len(_clouds(_messages(p))) for p in live_run["received"] if not _stamps([p]))
    # one stamp per cloud, in the same atomic update; viser sends a prop only when it changes: a frame of the
    # same cycle of the replayed loop as the one before (the loop came round) gets its stamp without a cloud
    assert stamps and unstamped == 0 and 0 < clouds <= len(stamps)
    assert sum(with_cloud for _, _, with_cloud in stamps) == clouds >= len(stamps) // 2
    frames = [f for f, _, _ in stamps]
    assert frames == sorted(set(frames)) and frames[-1] == FRAMES
    t0, t1 = live_run["wall"]  # arrival stamps are host wall-clock times (epoch ms) within the run
    assert all(t0 <= a <= t1 for _, a, _ in stamps)


@pytest.mark.browser
@pytest.mark.parametrize("run", ["live_run", "depth_run"])
def test_live_page_times_display_latency_of_the_frames_it_drew(run, request):
    live_run = request.getfixturevalue(run)
    t = live_run["timed"]
    frame, arrival = np.array(t["frame"]), np.array(t["arrival"])
    received, drawn, latency = np.array(t["received"]), np.array(t["drawn"]), np.array(t["latency"])
    tick = np.array(t["tick"])
    sent = {f: a for f, a, _ in _stamps(live_run["received"])}
    # the frames the page drew: frames the pipeline sent, in order, the last one included
    assert frame.size >= 1 and np.all(np.diff(frame) > 0) and frame[-1] == FRAMES
    assert frame.size <= live_run["summary"]["frames_shown"]
    np.testing.assert_allclose(arrival, [sent[f] for f in frame], atol=1e-3)  # the stamps sent with the clouds
    # one wall clock: arrival, then the page applied it, then drew it (Date.now() counts whole ms)
    assert np.all(arrival <= received + 1.0) and np.all(received <= drawn)
    np.testing.assert_allclose(latency, drawn - arrival)
    # the figures the page shows are NumPy's over its own list (linear percentiles, rounded to 0.1)
    shown = re.search(r"([0-9]+) 3D frames drawn, ([0-9.]+) frames/s; .* median ([0-9.]+) ms, p95 ([0-9.]+) ms, "
                      r"max ([0-9.]+) ms", t["shown"])
    assert shown, t["shown"]
    n, fps, median, p95, worst = (float(x) for x in shown.groups())
    assert n == frame.size
    expect_fps = (frame.size - 1) / ((tick[-1] - tick[0]) / 1e3) if frame.size > 1 else 0.0
    assert fps == pytest.approx(round(expect_fps, 1), abs=0.051)
    for figure, value in ((median, np.median(latency)), (p95, np.percentile(latency, 95)), (worst, latency.max())):
        assert figure == pytest.approx(round(float(value), 1), abs=0.051)


def _depth_frames(payloads: list[bytes]) -> list[tuple[int, np.ndarray | None, int]]:
    """(frame, decoded RGB image or None, messages in its websocket payload) of each frame stamp the page
    received: in the depth view the stamp is an ``<img>`` whose ``data:`` URL is the frame's JPEG."""
    import base64

    import cv2

    out = []
    for payload in payloads:
        messages = _messages(payload)
        for m in messages:
            content = m.get("updates", {}).get("content", "") if m.get("type") == "GuiUpdateMessage" else ""
            if FRAME_ATTRIBUTE not in content:
                continue
            frame = int(re.search(f'{FRAME_ATTRIBUTE}="([0-9]+)"', content).group(1))
            data = re.search(r'<img [^>]*src="data:image/jpeg;base64,([A-Za-z0-9+/=]+)"', content)
            image = None
            if data:
                bgr = cv2.imdecode(np.frombuffer(base64.b64decode(data.group(1)), np.uint8), cv2.IMREAD_COLOR)
                image = bgr[..., ::-1]
            out.append((frame, image, len(messages)))
    return out


@pytest.mark.browser
def test_live_depth_view_sends_each_frame_as_one_stamp_with_its_image_and_no_cloud(depth_run):
    received = depth_run["received"]
    frames = _depth_frames(received)
    assert not any(_clouds(_messages(p)) for p in received), "the depth view sent a point cloud"
    assert not any(m.get("type") == "GuiImageMessage" for p in received for m in _messages(p)
                   if m.get("props", {}).get("label") != "mask overlay")
    # every frame is its stamp with its image inline; viser drops updates a newer one replaces before they
    # are sent: not every frame travels, and those that do carry increasing numbers up to the last
    assert frames and all(image is not None for _, image, _ in frames)
    numbers = [f for f, _, _ in frames]
    assert numbers == sorted(set(numbers)) and numbers[-1] == FRAMES
    assert sum(n == 1 for *_, n in frames) >= len(frames) // 2  # most frames alone in their websocket message
    shown = depth_run["timed"]["depth_canvas"]  # the page draws them in its canvas, laid over the hidden 3D view
    assert shown == {"width": 160, "height": 128 + BAR_ROWS, "position": "fixed", "shown": True,
                     "view_hidden": True}


@pytest.mark.browser
def test_live_depth_images_decode_to_the_ramp_colours_of_the_engines_depths(depth_run, loop_points):
    from test_live_loop import ramp_colour

    from fringe3d.live.display import depth_image

    H, W = 128, 160
    maps = [m for *_, m in loop_points]
    made = [depth_image(points, quality, (300.0, 500.0)).astype(float) for points, quality in maps]
    for _, image, _ in _depth_frames(depth_run["received"]):
        assert image.shape == (H + BAR_ROWS, W, 3)
        error = [np.abs(image - m).mean() for m in made]
        k = int(np.argmin(error))
        assert error[k] < 3.0, "a depth image the page received is none of the loop's cycles"
        z = maps[k][0][..., 2]
        truth = ramp_colour(np.nan_to_num(z, nan=0.0), (300.0, 500.0))
        # a few pixels, each inside an 8x8 block (a JPEG block) of valid depths of nearly one colour
        picked = 0
        for v in range(8, H - 8, 24):
            for u in range(8, W - 8, 24):
                block = (slice(v - 4, v + 4), slice(u - 4, u + 4))
                if np.isfinite(z[block]).all() and np.ptp(truth[block], axis=(0, 1)).max() < 4:
                    assert np.abs(image[v, u] - truth[v, u]).max() <= 10, (v, u, image[v, u], truth[v, u])
                    picked += 1
        assert picked >= 5


def test_live_points_lie_on_the_rendered_scene_within_the_tiny_rigs_accuracy(loop_points):
    for _, pts, truth, on_scene, _ in loop_points:
        err = np.linalg.norm(pts[on_scene] - truth[on_scene], axis=1)
        assert on_scene.mean() > 0.97
        assert np.median(err) < 0.3  # mm; the tiny rig (160x128) at 400 mm, a moving ball
        assert np.percentile(err, 90) < 1.0


def test_viewer_waits_for_a_page_that_acknowledges_frames_and_not_for_one_that_never_does(monkeypatch):
    from fringe3d.live import viewer as viewer_module
    from fringe3d.live.session import Controls
    from fringe3d.live.viewer import IN_FLIGHT, ViewerSetup, ViserViewer

    v = ViserViewer(ViewerSetup(port=0), Controls(choice="3-step"))
    try:
        pts, cols = np.zeros((4, 3), np.float32), np.zeros((4, 3), np.uint8)
        for _ in range(IN_FLIGHT + 1):
            v.show_points(pts, cols, 0.0)
        assert not v.busy()  # no page said it runs the page script (none, or one without it)
        v._acknowledged("0")  # a page with the script started: it has drawn none of the frames sent
        assert v.busy()
        v._acknowledged("1")  # the page drew frame 1 of IN_FLIGHT + 1 sent
        assert v.busy()
        v._acknowledged("2")
        assert not v.busy()  # IN_FLIGHT - 1 frames in flight: send the next
        v.show_points(pts, cols, 0.0)
        assert v.busy()
        monkeypatch.setattr(viewer_module, "PATIENCE", 0.0)  # a page that stopped drawing is sent frames again
        assert not v.busy()
    finally:
        v.close()


def test_viewer_sends_a_depth_frame_as_its_stamp_with_the_image_inline():
    import base64

    import cv2

    from fringe3d.live.session import Controls
    from fringe3d.live.viewer import ViewerSetup, ViserViewer

    from fringe3d.live.display import depth_colours

    ramp = depth_colours(np.linspace(300.0, 500.0, 30), (300.0, 500.0)).reshape(6, 5, 3)  # the depth image's colours
    image = np.repeat(np.repeat(ramp, 16, axis=0), 16, axis=1)
    v = ViserViewer(ViewerSetup(port=0), Controls(choice="3-step"))
    try:
        before = time.time()
        v.show_depth(image, time.monotonic())
        after = time.time()
        content = v._stamp.content
    finally:
        v.close()
    assert re.fullmatch(f'<img {FRAME_ATTRIBUTE}="1" {ARRIVAL_ATTRIBUTE}="[0-9.]+" loading="lazy" '
                        r'src="data:image/jpeg;base64,[A-Za-z0-9+/=]+">', content)
    arrival = float(re.search(f'{ARRIVAL_ATTRIBUTE}="([0-9.]+)"', content).group(1))
    assert before * 1e3 - 1.0 <= arrival <= after * 1e3 + 1.0  # the arrival as epoch ms, the page's clock
    data = base64.b64decode(re.search(r"base64,([A-Za-z0-9+/=]+)", content).group(1))
    decoded = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)[..., ::-1]
    assert decoded.shape == image.shape
    # the mean colour of each uniform 16x16 block (a JPEG colour block) survives quality 90 within a few levels
    block_means = decoded.reshape(6, 16, 5, 16, 3).mean(axis=(1, 3))
    assert np.abs(block_means - image[::16, ::16]).max() < 4.0


@pytest.mark.browser
def test_page_draws_depth_frames_in_its_canvas_and_gives_the_3d_view_back_for_clouds():
    from playwright.sync_api import sync_playwright

    from fringe3d.live.session import Controls
    from fringe3d.live.viewer import ViewerSetup, ViserViewer

    state = f"""() => {{ const c = document.getElementById('{DEPTH_CANVAS_ID}');
      const gl = [...document.querySelectorAll('canvas')].find(x => x !== c);
      const px = c ? [...c.getContext('2d').getImageData(c.width / 2, c.height / 2, 1, 1).data] : null;
      return {{depth: c ? getComputedStyle(c).display : null, view: gl ? getComputedStyle(gl).display : null,
              size: c ? [c.width, c.height] : null, centre: px, frames: window.fringe3dDisplay.frame.slice()}}; }}"""
    image = np.zeros((64, 80, 3), np.uint8)
    image[..., 0], image[..., 2] = 200, 40  # one colour: its JPEG decodes to it within a level or two
    points = np.random.default_rng(0).normal(size=(100, 3)).astype(np.float32) + np.float32([0, 0, 400])
    v = ViserViewer(ViewerSetup(port=0), Controls(choice="3-step"))
    seen = []
    try:
        with sync_playwright() as p:
            browser = launch(p)
            page = browser.new_page(viewport={"width": 1000, "height": 700})
            page.goto(v.url)
            page.wait_for_function("() => window.fringe3dDisplay", timeout=30_000, polling=100)
            for k, view in enumerate(("depth", "cloud", "depth"), start=1):
                if view == "depth":
                    v.show_depth(image, time.monotonic())
                else:
                    v.show_points(points, np.zeros((100, 3), np.uint8), time.monotonic())
                page.wait_for_function(f"() => window.fringe3dDisplay.frame.includes({k})", timeout=30_000,
                                       polling=50)
                seen.append(page.evaluate(state))
            browser.close()
    finally:
        v.close()
    for s in (seen[0], seen[2]):  # the depth frames: in the page's canvas, at the image's size, the 3D view hidden
        assert s["depth"] != "none" and s["view"] == "none" and s["size"] == [80, 64]
        assert np.abs(np.array(s["centre"][:3]) - [200, 0, 40]).max() <= 4 and s["centre"][3] == 255
    assert seen[1]["depth"] == "none" and seen[1]["view"] != "none"  # a cloud gives the 3D view back
    assert seen[2]["frames"] == [1, 2, 3]  # each frame drawn, timed once


def test_viewer_keeps_one_more_depth_image_than_clouds_in_flight():
    from fringe3d.live.session import Controls
    from fringe3d.live.viewer import IN_FLIGHT, IN_FLIGHT_DEPTH, ViewerSetup, ViserViewer

    assert IN_FLIGHT_DEPTH == IN_FLIGHT + 1
    v = ViserViewer(ViewerSetup(port=0), Controls(choice="3-step"))
    try:
        image = np.zeros((16, 16, 3), np.uint8)
        v._acknowledged("0")  # a page with the script, nothing drawn yet
        for _ in range(IN_FLIGHT):
            v.show_depth(image, 0.0)
        assert not v.busy()  # IN_FLIGHT depth images not drawn: one more may go
        v.show_depth(image, 0.0)
        assert v.busy()
        v.show_points(np.zeros((4, 3), np.float32), np.zeros((4, 3), np.uint8), 0.0)
        v._acknowledged(str(IN_FLIGHT_DEPTH + 1 - IN_FLIGHT))  # IN_FLIGHT frames not drawn, the last a cloud
        assert v.busy()
    finally:
        v.close()


@pytest.mark.browser
def test_page_acknowledges_each_drawn_frame_through_visers_websocket_worker_not_the_typed_field():
    from playwright.sync_api import sync_playwright

    from fringe3d.live.page_script import ACK_LABEL
    from fringe3d.live.session import Controls
    from fringe3d.live.viewer import ViewerSetup, ViserViewer

    def wait_drawn(v, frame):  # the acknowledgement crosses the websocket after the page drew the frame
        end = time.monotonic() + 30
        while v.drawn < frame and time.monotonic() < end:
            time.sleep(0.01)
        return v.drawn

    image = np.zeros((32, 40, 3), np.uint8)
    v = ViserViewer(ViewerSetup(port=0), Controls(choice="3-step"))
    try:
        with sync_playwright() as p:
            browser = launch(p)
            page = browser.new_page(viewport={"width": 800, "height": 600})
            page.goto(v.url)
            page.wait_for_function("() => window.fringe3dDisplay", timeout=30_000, polling=100)
            assert wait_drawn(v, 0) == 0  # "drew frame 0", typed into the field: the page runs the script
            acked = []
            for k in range(1, 5):
                v.show_depth(image, time.monotonic())
                page.wait_for_function(f"() => window.fringe3dDisplay.frame.includes({k})", timeout=30_000,
                                       polling=50)
                acked.append(wait_drawn(v, k))
            drawn = page.evaluate("() => window.fringe3dDisplay.frame.slice()")
            how = page.evaluate("() => window.fringe3dDisplay.acknowledged")
            typed = page.evaluate(GUI_VALUE, ACK_LABEL)
            browser.close()
    finally:
        v.close()
    assert drawn == [1, 2, 3, 4] and acked == drawn  # the viewer learns each frame the page drew, in order
    assert how == "worker" and typed == "0"  # after the first, sent to viser's worker: the field is never retyped
