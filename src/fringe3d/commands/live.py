"""``fringe3d live``: camera -> decode -> 3D, shown continuously in a browser (fringe3d.live)."""
from __future__ import annotations

import math
import signal
import time
import warnings
from dataclasses import dataclass, fields
from pathlib import Path

import typer

from fringe3d.decode import DecodeOptions
from fringe3d.commands.capture import open_rig
from fringe3d.devices import DeviceSpec, open_camera
from fringe3d.devices.acquire import configure_camera
from fringe3d.devices.base import DeviceError
from fringe3d.io.pattern_folder import read_pattern_folder
from fringe3d.live import (
    CameraCycles,
    Choice,
    Controls,
    ExposureControl,
    LiveSession,
    LiveSettings,
    RecordSettings,
    ReplayCamera,
    ViewerSetup,
    ViserViewer,
    require_viser,
)
from fringe3d.live.display import COLOURINGS, VIEWS
from fringe3d.optics import Rig
from fringe3d.patterns.render import render_set
from fringe3d.reconstruct.frame import FrameReconstructor, reconstruction_plans
from fringe3d.sim import presets
from fringe3d.sim.live_take import LIVE_PATTERNS, THREE_STEP, live_patterns, render_take
from fringe3d.utils.console import console, info, make_table, print_json, set_quiet
from fringe3d.utils.warning_types import Fringe3DWarning
from fringe3d.commands.flag_words import in_flag_words
from fringe3d.commands.output_options import overwrite_option
from fringe3d.commands.vocabulary import set_option


def register(app: typer.Typer) -> None:
    @app.command("live")
    def live(
        camera: str = typer.Option("virtual", help="Camera: virtual[:PRESET][?seed=N] (a rendered moving scene "
                                                   "replayed as a camera delivers it), or any camera of fringe3d "
                                                   "capture: pylon:SERIAL, genicam:PRODUCER.cti#SERIAL, "
                                                   "opencv:INDEX."),
        projector: str = typer.Option(None, help="Projector showing the patterns for a real camera (software sync: "
                                                 "show, trigger, grab), e.g. window:1; without it the camera runs "
                                                 "free and its frame ids say which pattern each frame shows. "
                                                 "virtual[:PRESET] renders every frame as it is triggered "
                                                 "(slow; for checking the device path)."),
        patterns: str = set_option(THREE_STEP, "Pattern set(s) the page offers, comma-separated, the first "
                                   "shown first. Virtual camera: " + ", ".join(LIVE_PATTERNS[:4])
                                   + ", ... (fringe3d simulate's names); a real rig: pattern folders "
                                   "(fringe3d patterns)."),
        calibration: Path = typer.Option(None, "-c", "--calibration", help="Real rig: the calibration (or rig) "
                                                                             "file."),
        z_min: float = typer.Option(None, "--z-min", help="Nearest depth (mm) for geometric unwrapping on a real "
                                                          "rig (the virtual take knows its own)."),
        frame_rate: float = typer.Option(120.0, "--frame-rate", help="Virtual camera: frames per second it "
                                                                     "delivers."),
        loop_cycles: int = typer.Option(8, "--loop-cycles", help="Virtual camera: pattern cycles rendered once and "
                                                                 "replayed in a loop."),
        exposure: float = typer.Option(None, help="Starting exposure: the virtual camera's gain (a factor, 1 = as "
                                                  "rendered) or a real camera's exposure time (s)."),
        frames: int = typer.Option(None, help="Stop after showing this many 3D frames (default: until Ctrl-C)."),
        seconds: float = typer.Option(None, help="Stop after this many seconds of showing."),
        host: str = typer.Option("127.0.0.1", help="Address the page is served on."),
        port: int = typer.Option(8080, help="Port of the page (0: any free port)."),
        step: int = typer.Option(1, help="Draw every STEP-th pixel in both directions."),
        colour: str = typer.Option("z", help="Colour the points by z (depth) or texture."),
        show: str = typer.Option("depth", help="What the page shows first (it can switch): the depth map as "
                                               "an image coloured by depth, masked pixels by reason (drawn "
                                               "without WebGL: fast in any browser), or the point cloud (WebGL: "
                                               "slow in a browser without a GPU)."),
        output: Path = typer.Option(Path("live-recording"), "-o", "--output",
                                    help="The capture folder the page's record button writes (the page can change "
                                         "it; a non-empty one only with --overwrite)."),
        record_cycles: int = typer.Option(1, "--record-cycles", help="Pattern cycles one recording takes."),
        wait_viewer: float = typer.Option(0.0, "--wait-viewer", help="Seconds to wait for a page to connect "
                                                                      "before the first frame."),
        hold: float = typer.Option(0.0, help="Seconds to keep the page served after the last frame."),
        overwrite: bool = overwrite_option(),
        json_: bool = typer.Option(False, "--json", help="Print a JSON summary at the end."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress output."),
    ) -> None:
        """Show camera frames as 3D in a browser, continuously: capture, decode, triangulate, draw.

        The page (http://HOST:PORT) shows the point cloud or the depth map (--show), the mask
        overlay, the frame rate and the end-to-end latency (frame arrival to the frame sent to the
        page), with exposure, pattern-set, colour, show, pause and record controls. The default
        camera replays a rendered moving scene as a camera delivers it. Runs until Ctrl-C, --frames
        or --seconds; --json prints the figures.

        Example: fringe3d live

        Example: fringe3d live --camera virtual:high-speed --loop-cycles 16 --seconds 20 --json

        Example: fringe3d live --camera pylon:40012345 --projector window:1 --set pats --calibration rig.json
        """
        opts = dict(locals())
        o = LiveOptions(**{f.name: opts[f.name] for f in fields(LiveOptions)})
        try:
            summary = run_live(o)
        except (ValueError, FileNotFoundError) as e:
            raise ValueError(in_flag_words(str(e))) from None
        _report(summary, o)


@dataclass(frozen=True)
class LiveOptions:
    """The ``fringe3d live`` flags."""

    camera: str
    projector: str | None
    patterns: str
    calibration: Path | None
    z_min: float | None
    frame_rate: float
    loop_cycles: int
    exposure: float | None
    frames: int | None
    seconds: float | None
    host: str
    port: int
    step: int
    colour: str
    show: str
    output: Path
    record_cycles: int
    wait_viewer: float
    hold: float
    overwrite: bool
    json_: bool
    quiet: bool


@dataclass
class _Rig:
    """What the chosen camera brings: the choices, the rig, the exposure slider and its setter,
    capture.json fields for recordings, the depth range drawn and the devices to close."""

    choices: list
    rig: Rig
    exposure: ExposureControl | None
    apply_exposure: object
    meta: dict
    z_range: tuple
    closing: list


def _names(text: str) -> list[str]:
    names = [n.strip() for n in str(text).split(",") if n.strip()]
    if not names:
        raise ValueError("--set names no pattern set")
    return names


def _virtual(o: LiveOptions, spec: DeviceSpec) -> _Rig:
    """The replayed virtual take(s): one rendered loop per pattern set."""
    camera_settings = dict(spec.options)  # the device spec's ?key=value part (not a plan's options)
    unknown = sorted(set(camera_settings) - {"seed"})
    if unknown:
        raise ValueError(f"virtual live camera: unknown option(s) {unknown}; allowed: ['seed']")
    seed = int(camera_settings.get("seed", 0))
    if o.loop_cycles < 1:
        raise ValueError(f"--loop-cycles must be at least 1, got {o.loop_cycles}")
    choices, cams = [], []
    for name in _names(o.patterns):
        info(f"rendering the virtual take: {o.loop_cycles} cycles of {name} on the {spec.ident or 'tiny'} rig")
        take = render_take(spec.ident or "tiny", name, o.loop_cycles, o.frame_rate, seed=seed)
        cam = ReplayCamera(take.frames, take.frame_rate)
        if o.exposure is not None:
            cam.gain = o.exposure
        engine = FrameReconstructor(reconstruction_plans(take.patterns, take.method), take.preset.rig,
                                    DecodeOptions(z_min=take.z_min, bit_depth=cam.bit_depth))
        choices.append(Choice(name, CameraCycles(cam, take.patterns, name=name), engine))
        cams.append(cam)
        rig, volume = take.preset.rig, take.preset.volume

    def apply(gain: float) -> None:
        for c in cams:
            c.gain = gain

    first = cams[0]
    meta = {"frame_rate": first.frame_rate, "bit_depth": first.bit_depth, "camera_device": first.describe(),
            "simulated": True, "preset": spec.ident or "tiny", "seed": seed}
    slider = ExposureControl("exposure (virtual gain)", min(0.1, first.gain), max(3.0, first.gain), 0.05, first.gain)
    return _Rig(choices, rig, slider, apply, meta, tuple(volume["z"]), [])


def _devices(o: LiveOptions, spec: DeviceSpec) -> _Rig:
    """A real camera (and projector), or the capture command's virtual rig rendering every frame."""
    virtual = spec.backend == "virtual"
    if o.calibration is None and not virtual:
        raise ValueError("a real camera needs --calibration (the rig's calibration file) to triangulate")
    preset = presets.get(DeviceSpec.parse(o.projector).ident or "tiny") if virtual else None
    loaded = []
    for name in _names(o.patterns):
        if preset is not None:  # the virtual rig's own pattern sets
            ps, method = live_patterns(name, preset)
            loaded.append((name, ps, list(render_set(ps)), method))
        else:
            ps, images, _ = read_pattern_folder(Path(name))
            loaded.append((name, ps, images, None))
    if o.projector is None and len(loaded) > 1:
        raise ValueError("a free-running camera shows one pattern set; give --projector to switch between several")
    if preset is not None:
        rig, z_range = preset.rig, tuple(preset.volume["z"])
        z_min = o.z_min if o.z_min is not None else z_range[0]
    else:
        rig = Rig.load(o.calibration)
        z_min, z_range = o.z_min, (o.z_min or 0.0, (o.z_min or 0.0) + 500.0)
    proj, cam = open_rig(o.projector, o.camera, patterns=loaded[0][1]) if o.projector else (None, open_camera(spec))
    devices = [d for d in (cam, proj) if d is not None]
    try:
        if o.exposure is not None:
            configure_camera(cam, exposure=o.exposure)
        bit_depth = {"Mono8": 8, "Mono10": 10, "Mono12": 12}.get(getattr(cam, "pixel_format", "Mono8"), 8)
        choices = [Choice(name, CameraCycles(cam, ps, proj, images, name=name),
                          FrameReconstructor(reconstruction_plans(ps, method), rig,
                                             DecodeOptions(z_min=z_min, bit_depth=bit_depth)))
                   for name, ps, images, method in loaded]
        ms = float(cam.exposure) * 1e3
        meta = {"bit_depth": bit_depth, "camera_device": cam.describe(),
                "projector": proj.describe() if proj is not None else None}
    except BaseException:
        for d in devices:
            d.close()
        raise

    def apply(value_ms: float) -> None:
        cam.exposure = value_ms / 1e3

    slider = (ExposureControl("exposure (ms)", ms / 10, ms * 10, ms / 100, ms) if math.isfinite(ms) and ms > 0
              else None)  # a camera without an exposure time (a webcam) gets no slider
    return _Rig(choices, rig, slider, apply, meta, z_range, devices)


def run_live(o: LiveOptions, on_serving=None) -> dict:
    """The body of ``fringe3d live`` (see its --help): open the camera, serve the page, run the
    loop, and return the summary ``--json`` prints.

    Parameters
    ----------
    o : LiveOptions
        The flags.
    on_serving : callable, optional
        Called with the page's address once it is served (tests open it then).

    Returns
    -------
    dict
        The figures of :meth:`fringe3d.live.LiveSession.run` plus the camera, size, engine path,
        pattern sets, address and whether Ctrl-C stopped the run.
    """
    set_quiet(o.quiet or o.json_)
    if o.frames is not None and o.frames < 1:
        raise ValueError(f"--frames must be at least 1, got {o.frames}")
    if o.seconds is not None and o.seconds <= 0:
        raise ValueError(f"--seconds must be positive, got {o.seconds}")
    if o.record_cycles < 1:
        raise ValueError(f"--record-cycles must be at least 1, got {o.record_cycles}")
    if o.colour not in COLOURINGS:
        raise ValueError(f"--colour must be one of {', '.join(COLOURINGS)}, got {o.colour!r}")
    if o.show not in VIEWS:
        raise ValueError(f"--show must be one of {', '.join(VIEWS)}, got {o.show!r}")
    require_viser()  # before rendering or opening anything: the page needs the live extra
    spec = DeviceSpec.parse(o.camera)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Fringe3DWarning)  # a moving scene's per-cycle notices would flood the console
        rig = _virtual(o, spec) if spec.backend == "virtual" and o.projector is None else _devices(o, spec)
    controls = Controls(choice=rig.choices[0].name, colouring=o.colour, view=o.show)
    first = rig.choices[0]
    H, W = first.source.camera.roi[3], first.source.camera.roi[2]
    setup = ViewerSetup(host=o.host, port=o.port, choices=tuple(c.name for c in rig.choices), exposure=rig.exposure,
                        record_folder=str(o.output), record_cycles=o.record_cycles,
                        point_size=_point_size(rig.rig, rig.z_range, o.step),
                        look_at=(0.0, 0.0, 0.5 * (rig.z_range[0] + rig.z_range[1])))
    try:
        viewer = ViserViewer(setup, controls)
    except BaseException:
        for d in rig.closing:
            d.close()
        raise
    info(f"live view at {viewer.url} ({W}x{H} camera, {first.engine.path}); Ctrl-C stops")
    if on_serving is not None:
        on_serving(viewer.url)
    settings = LiveSettings(frames=o.frames, seconds=o.seconds, step=o.step, z_range=rig.z_range,
                            wait_viewer=o.wait_viewer)
    session = LiveSession(rig.choices, viewer, settings, controls, rig.apply_exposure,
                          RecordSettings(meta=rig.meta, rig=rig.rig, overwrite=o.overwrite,
                                         describe_error=lambda e: in_flag_words(str(e))))
    previous = _stop_on_ctrl_c(session)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Fringe3DWarning)
            summary = session.run()
        interrupted = session.controls.stop
        if o.hold > 0 and not interrupted:
            time.sleep(o.hold)
    except (DeviceError, TimeoutError) as e:
        raise ValueError(f"device error: {e}") from None
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
        viewer.close()
        for d in rig.closing:
            d.close()
    return {**summary, "camera": o.camera, "size": [int(W), int(H)], "path": first.engine.path,
            "patterns": [c.name for c in rig.choices], "url": viewer.url, "interrupted": interrupted}


def _stop_on_ctrl_c(session: LiveSession):
    """Make Ctrl-C finish the session after its current cycle (a second one interrupts); the
    handler it replaces, to restore (None outside the main thread)."""
    try:
        previous = signal.getsignal(signal.SIGINT)

        def stop(signum, frame) -> None:
            session.stop()
            signal.signal(signal.SIGINT, previous)

        signal.signal(signal.SIGINT, stop)
        return previous
    except ValueError:  # not the main thread
        return None


def _point_size(rig: Rig, z_range: tuple, step: int) -> float:
    """A drawn point's size (mm): one (decimated) pixel's footprint at mid depth."""
    K = getattr(rig.camera, "K", None)
    f = float(K[0, 0]) if K is not None else 1000.0
    return 0.5 * (z_range[0] + z_range[1]) / f * step


def _report(summary: dict, o: LiveOptions) -> None:
    if o.json_:
        print_json(summary)
        return
    if o.quiet:
        return
    lat = summary["latency_ms"]
    console.print(make_table("live view", ["figure", "value"], [
        ["3D frames shown", summary["frames_shown"]], ["3D frames/s", summary["fps"]],
        ["latency median (ms)", lat["median"]], ["latency p95 (ms)", lat["p95"]],
        ["cycles arrived", summary["cycles_arrived"]], ["cycles skipped", summary["cycles_skipped"]],
        ["points per frame (median)", summary["points_median"]]]))
    for r in summary["recordings"]:
        console.print(f"recorded {r['folder']}" if "error" not in r else f"not recorded: {r['error']}")
