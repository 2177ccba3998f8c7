"""The live loop's parts without a browser: the replay camera's timing, the cycle assembly, the
figures, the page's controls (pause, exposure, record) acting on a session with a recording
viewer, and recordings read back as capture folders."""
from __future__ import annotations

import json

import numpy as np
import pytest

from fringe3d.decode import DecodeOptions
from fringe3d.devices.base import Frame
from fringe3d.io.capture import read_capture
from fringe3d.live import (
    CameraCycles,
    Choice,
    LiveSession,
    LiveSettings,
    LiveStats,
    RecordSettings,
    ReplayCamera,
)
from fringe3d.live.display import BAR_ROWS, depth_image, display_points, mask_overlay
from fringe3d.live.replay import BUFFER_FRAMES
from fringe3d.decode.edges import INVALID
from fringe3d.optics import Rig
from fringe3d.pipeline import reconstruct_capture
from fringe3d.patterns import sets
from fringe3d.patterns.render import render_set
from fringe3d.reconstruct.frame import FrameReconstructor, reconstruction_plans
from fringe3d.sim import Plane, Scene, presets, render
from fringe3d.sim.simulate import make_scene
from fringe3d.sim.virtual_devices import open_virtual_rig

TINY_Z_MIN = 340.0


class Clock:
    """A host clock the test moves by hand."""

    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_replay_camera_delivers_frames_at_their_due_times_with_consecutive_ids():
    frames = np.arange(4 * 2 * 3, dtype=np.uint8).reshape(4, 2, 3)
    clock = Clock()
    cam = ReplayCamera(frames, frame_rate=50.0, clock=clock)
    cam.start()
    clock.t += 0.1  # five frames are due: they wait in the buffer, stamped when they arrived
    got = [cam.grab(1.0) for _ in range(6)]
    assert [f.frame_id for f in got] == [0, 1, 2, 3, 4, 5]
    assert [f.host_time for f in got] == pytest.approx([100.0 + k / 50.0 for k in range(6)])
    assert np.array_equal(got[5].image, frames[1])  # the stack repeats


def test_a_consumer_later_than_the_buffer_loses_the_oldest_frames_and_their_ids():
    clock = Clock()
    cam = ReplayCamera(np.zeros((3, 2, 2), np.uint8), frame_rate=100.0, clock=clock)
    cam.start()
    clock.t += 1.0  # frames 0..100 are due; the buffer keeps the newest BUFFER_FRAMES
    first = cam.grab(1.0)
    assert first.frame_id == 100 - BUFFER_FRAMES + 1
    assert cam.lost == first.frame_id


def test_replay_gain_scales_the_signal_and_clips_at_full_scale():
    cam = ReplayCamera(np.array([[[10, 100, 200]]], np.uint8), frame_rate=10.0)
    cam.gain = 2.0
    assert cam.image(0).tolist() == [[20, 200, 255]]
    cam.exposure = 0.05  # half the frame period: half the signal
    assert cam.gain == 0.5 and cam.image(0).tolist() == [[5, 50, 100]]
    with pytest.raises(ValueError, match="positive factor"):
        cam.gain = 0.0


class IdCamera:
    """A free-running camera delivering the given frame ids (image = the id)."""

    def __init__(self, ids):
        self.ids = list(ids)
        self.trigger_mode = "off"

    def start(self):
        pass

    def stop(self):
        pass

    def grab(self, timeout):
        k = self.ids.pop(0)
        return Frame(np.full((1, 1), k, np.uint8), k, 0.0, host_time=float(k))


def test_free_running_cycles_start_at_the_first_pattern_and_drop_a_cycle_with_a_lost_frame():
    ps = sets.phase_shift(32, 3, "v", width=64, height=32)
    src = CameraCycles(IdCamera([1, 2, 3, 4, 5, 6, 7, 9, 10, 11]), ps)
    a, b = src.next_cycle(), src.next_cycle()
    assert a.frames.ravel().tolist() == [3, 4, 5] and a.first_id == 3 and a.arrival == 5.0
    assert b.frames.ravel().tolist() == [9, 10, 11]  # 6, 7 and a lost 8: that cycle is dropped


def test_stats_give_the_rate_between_first_and_last_frame_and_latency_percentiles():
    st = LiveStats()
    lat = [0.010, 0.020, 0.030, 0.040, 0.100]
    for k, d in enumerate(lat):
        st.shown(arrival=k * 0.05, sent=k * 0.05 + d, points=10 + k)
    s = st.summary()
    sent = np.array([k * 0.05 + d for k, d in enumerate(lat)])
    assert s["fps"] == round(4 / (sent[-1] - sent[0]), 1)
    assert s["latency_ms"]["median"] == 30.0
    assert s["latency_ms"]["p95"] == round(float(np.percentile(np.array(lat) * 1e3, 95)), 1)
    assert s["points_median"] == 12 and s["frames_shown"] == 5


def test_display_points_keep_the_engines_values_and_colour_by_texture_or_depth():
    pts = np.full((4, 4, 3), np.nan, np.float32)
    pts[1, 2] = (1.5, -2.0, 350.25)
    pts[2, 2] = (0.0, 0.0, 450.0)
    tex = np.full((4, 4), 0.5, np.float32)
    p, c = display_points(pts, tex, "texture", (300.0, 500.0))
    assert np.array_equal(p, pts[[1, 2], [2, 2]]) and c.tolist() == [[128] * 3] * 2
    p, c = display_points(pts, None, "z", (350.25, 450.0))
    assert c[0].tolist() == [68, 1, 84] and c[1].tolist() == [253, 231, 37]  # the ramp's two ends
    p, _ = display_points(pts, None, "z", (300.0, 500.0), step=2)
    assert np.array_equal(p, pts[2, 2][None])  # (1, 2) is off the even grid, (2, 2) on it


def test_mask_overlay_tints_invalid_pixels_red_and_other_masked_pixels_orange():
    q = np.array([[0, INVALID, 2]], np.uint8)
    img = mask_overlay(np.full((1, 3), 0.5, np.float32), q)
    assert img[0, 0].tolist() == [128, 128, 128]
    assert img[0, 1, 0] > 150 and img[0, 1, 1] == 0  # red
    assert img[0, 2, 0] > 150 and 0 < img[0, 2, 1] < img[0, 2, 0] and img[0, 2, 2] == 0  # orange


#: The depth ramp's five stops (viridis at 0, 1/4, 1/2, 3/4, 1): the truth of the depth colours.
VIRIDIS_STOPS = np.array([[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]], float)


def ramp_colour(z, z_range):
    """The colour of depth z: the stops interpolated linearly over z_range (clipped), rounded."""
    t = np.clip((np.asarray(z, float) - z_range[0]) / (z_range[1] - z_range[0]), 0.0, 1.0) * 4
    return np.stack([np.interp(t, np.arange(5), VIRIDIS_STOPS[:, c]) for c in range(3)], -1)


def test_depth_image_colours_depths_on_the_ramp_and_masked_pixels_like_the_overlay():
    H, W = 6, 256
    pts = np.zeros((H, W, 3), np.float32)
    pts[..., 2] = np.linspace(280.0, 520.0, W, dtype=np.float32)[None]  # beyond the range at both ends
    pts[1, 10], pts[2, 20], pts[3, 30] = np.nan, np.nan, np.nan
    q = np.zeros((H, W), np.uint8)
    q[1, 10], q[2, 20] = INVALID | 2, 2  # no quality bit at (3, 30): a pixel without depth is invalid
    img = depth_image(pts, q, (300.0, 500.0))
    assert img.shape == (H + BAR_ROWS, W, 3) and img.dtype == np.uint8
    kept = np.isfinite(pts[..., 2])
    # one step of the 256-colour ramp at most from the linear interpolation of the stops
    assert np.abs(img[:H][kept] - ramp_colour(pts[..., 2][kept], (300.0, 500.0))).max() <= 1.5
    assert img[0, 0].tolist() == [68, 1, 84] and img[0, -1].tolist() == [253, 231, 37]  # clipped to the ends
    grey = mask_overlay(None, np.array([[INVALID, 2]], np.uint8))  # the overlay's tints on mid grey
    assert img[1, 10].tolist() == grey[0, 0].tolist() == img[3, 30].tolist()
    assert img[2, 20].tolist() == grey[0, 1].tolist()
    bar = img[H:H + BAR_ROWS // 2]  # the colour bar: the ramp over the range, left to right
    assert np.abs(bar[0] - ramp_colour(np.linspace(300.0, 500.0, W), (300.0, 500.0))).max() <= 1.5
    assert (img[H + BAR_ROWS // 2:] < 128).any()  # the range's labels, dark on white
    half = depth_image(pts, q, (300.0, 500.0), step=2)
    assert np.array_equal(half[:H // 2], img[:H:2, ::2])


# ----------------------------------------------------------------------------- a session without a browser
class RecordingViewer:
    """A viewer that keeps what it was given; its controls are driven by the test."""

    def __init__(self):
        self.clouds: list = []
        self.depth: list = []
        self.arrivals: list = []
        self.stats: list = []
        self.status: list = []
        self.on_frame = None

    def show_points(self, points, colours, arrival):
        self.clouds.append(points)
        self.arrivals.append(arrival)
        if self.on_frame is not None:
            self.on_frame(len(self.clouds))

    def show_depth(self, image, arrival):
        self.depth.append(image)
        self.arrivals.append(arrival)

    def show_overlay(self, image):
        pass

    def busy(self):
        return False

    def show_stats(self, summary):
        self.stats.append(summary)

    def show_status(self, text):
        self.status.append(text)

    def clients(self):
        return 1


@pytest.fixture(scope="module")
def plane_take():
    p = presets.get("tiny")
    ps = sets.phase_shift(32, 3, "v", width=p.rig.projector.width, height=p.rig.projector.height)
    frames, truth = render(Scene([Plane(p.center, (0, 0, -1))]), p.rig, ps, p.settings.replace(seed=0),
                           times=np.arange(6) / 100.0, progress=False)
    return frames, truth, ps, p.rig


def _session(take, viewer, frames=4, record=None, apply_exposure=None, seconds=None):
    frames_, _, ps, rig = take
    cam = ReplayCamera(frames_, frame_rate=300.0)
    engine = FrameReconstructor(reconstruction_plans(ps, "geometric"), rig,
                                DecodeOptions(z_min=TINY_Z_MIN, bit_depth=8))
    return LiveSession([Choice("3-step", CameraCycles(cam, ps, name="3-step"), engine)], viewer,
                       LiveSettings(frames=frames, seconds=seconds, z_range=(300.0, 500.0)),
                       apply_exposure=apply_exposure,
                       record=record), cam


def test_session_shows_the_plane_the_engine_reconstructs(plane_take):
    viewer = RecordingViewer()
    session, _ = _session(plane_take, viewer)
    summary = session.run()
    assert summary["frames_shown"] == 4 == len(viewer.clouds)
    _, truth, _, _ = plane_take
    z = np.concatenate([c[:, 2] for c in viewer.clouds])
    assert np.median(np.abs(z - np.median(truth.depth[truth.mask]))) < 0.2  # a plane at the truth's depth
    assert viewer.stats[-1] == summary


def test_depth_view_shows_the_depth_image_of_the_cycle_and_no_cloud(plane_take):
    viewer = RecordingViewer()
    session, _ = _session(plane_take, viewer)
    session.controls.view = "depth"
    summary = session.run()
    assert summary["frames_shown"] == 4 == len(viewer.depth) and not viewer.clouds
    _, truth, _, _ = plane_take
    img = viewer.depth[-1]
    depth, mask = truth.depth.reshape(-1, *truth.depth.shape[-2:])[0], truth.mask.reshape(-1, *truth.mask.shape[-2:])[0]
    H, W = depth.shape
    assert img.shape == (H + BAR_ROWS, W, 3)
    on = mask & (img[:H, :, 0] != 201)  # the plane, where the engine kept a depth
    assert on.mean() > 0.9 * mask.mean()
    expect = ramp_colour(depth[on], (300.0, 500.0))  # a still plane: the same depth in every cycle
    assert np.median(np.abs(img[:H][on] - expect)) <= 1.5
    assert summary["points_median"] == int(np.median([np.count_nonzero(d[:H, :, 0] != 201) for d in viewer.depth]))


def test_pause_shows_nothing_new_and_exposure_reaches_the_camera(plane_take):
    viewer = RecordingViewer()
    applied: list = []
    session, cam = _session(plane_take, viewer, frames=3, apply_exposure=applied.append, seconds=1.0)

    def on_frame(n):
        if n == 1:
            session.controls.paused = True
            session.controls.exposure = 1.5

    viewer.on_frame = on_frame
    summary = session.run()
    assert summary["frames_shown"] == 1 and len(viewer.clouds) == 1  # paused after the first: the time limit ended it
    assert summary["cycles_skipped"] > 0
    assert applied == [1.5]


def test_record_writes_a_capture_folder_the_other_commands_read(plane_take, tmp_path):
    frames_, _, ps, rig = plane_take
    viewer = RecordingViewer()
    session, _ = _session(plane_take, viewer, frames=6, record=RecordSettings(meta={"bit_depth": 8}, rig=rig))
    session.controls.record = (tmp_path / "rec", 2)
    summary = session.run()
    assert summary["recordings"] == [{"folder": str(tmp_path / "rec"), "frames": 6, "cycles": 2}]
    cap = read_capture(tmp_path / "rec")
    assert cap.frames.shape == (6,) + frames_.shape[1:]
    assert all(any(np.array_equal(cap.frames[k], f) for f in frames_) for k in range(6))
    assert Rig.load(tmp_path / "rec" / "rig.json").to_dict() == rig.to_dict()
    assert cap.meta["reconstruct"] == {"method": "geometric", "z_min": TINY_Z_MIN}
    # what `fringe3d reconstruct` makes of the recording is what the live engine showed for that cycle
    again = reconstruct_capture(tmp_path / "rec", tmp_path / "rec" / "rig.json", method="geometric", z_min=TINY_Z_MIN)
    engine = FrameReconstructor(reconstruction_plans(ps, "geometric"), rig,
                                DecodeOptions(z_min=TINY_Z_MIN, bit_depth=8))
    assert np.array_equal(again.points, engine.reconstruct(cap.frames[:3]).points, equal_nan=True)


def test_record_refuses_a_folder_that_is_not_empty_and_says_so_on_the_page(plane_take, tmp_path):
    (tmp_path / "rec").mkdir()
    (tmp_path / "rec" / "keep.txt").write_text("mine")
    viewer = RecordingViewer()
    session, _ = _session(plane_take, viewer, frames=4, record=RecordSettings(meta={"bit_depth": 8}))
    session.controls.record = (tmp_path / "rec", 1)
    summary = session.run()
    assert "not empty" in summary["recordings"][0]["error"]
    assert any(s.startswith("not recorded:") and "not empty" in s for s in viewer.status)
    assert (tmp_path / "rec" / "keep.txt").read_text() == "mine"


# ----------------------------------------------------------------------------- the device path and the command
def test_software_synced_cycles_from_the_virtual_rig_equal_the_simulators_frames():
    p = presets.get("tiny")
    ps = sets.phase_shift(32, 3, "v", width=p.rig.projector.width, height=p.rig.projector.height)
    proj, cam = open_virtual_rig("virtual:tiny", "virtual:tiny?scene=plane", patterns=ps)
    src = CameraCycles(cam, ps, projector=proj, images=render_set(ps))
    try:
        got = [src.next_cycle() for _ in range(2)]
    finally:
        src.stop()
    frames, _ = render(make_scene("plane", p), p.rig, ps, p.settings.replace(seed=0),
                       times=np.arange(6) / p.settings.frame_rate, progress=False)
    assert [a.first_id for a in got] == [0, 3]
    assert np.array_equal(np.concatenate([a.frames for a in got]), frames)  # same frames, same noise


def test_switching_the_pattern_set_takes_cycles_from_the_other_source(plane_take):
    frames_, _, ps, rig = plane_take
    opts = DecodeOptions(z_min=TINY_Z_MIN, bit_depth=8)
    cams = {n: ReplayCamera(frames_, frame_rate=300.0) for n in ("a", "b")}
    viewer = RecordingViewer()
    session = LiveSession([Choice(n, CameraCycles(cams[n], ps, name=n),
                                  FrameReconstructor(reconstruction_plans(ps, "geometric"), rig, opts)) for n in cams],
                          viewer, LiveSettings(frames=6, z_range=(300.0, 500.0)))
    viewer.on_frame = lambda n: setattr(session.controls, "choice", "b") if n == 2 else None
    session.run()
    assert cams["b"].lost + cams["b"]._next > 0  # b delivered frames once chosen
    assert len(viewer.clouds) == 6


def test_live_command_runs_the_device_path_and_prints_its_summary(capsys):
    from fringe3d.cli import main
    rc = main(["live", "--camera", "virtual:tiny?scene=plane", "--projector", "virtual:tiny", "--frames", "2",
               "--port", "0", "--json"])
    out = capsys.readouterr().out
    assert rc == 0, out
    s = json.loads(out)
    assert s["frames_shown"] == 2 and s["size"] == [160, 128] and s["latency_ms"]["median"] > 0


def test_a_missing_viser_names_the_live_extra(monkeypatch):
    import importlib

    from fringe3d.devices import MissingExtraError
    from fringe3d.live import require_viser

    real = importlib.import_module

    def no_viser(name, *a, **k):
        if name == "viser":
            raise ImportError("No module named 'viser'")
        return real(name, *a, **k)

    monkeypatch.setattr(importlib, "import_module", no_viser)
    with pytest.raises(MissingExtraError, match=r"fringe3d\[live\]"):
        require_viser()
