"""``fringe3d capture``: project a pattern folder with a real (or the virtual) rig into a capture folder.

Also: ``--latency`` (display-to-camera delay), ``--gamma`` (projector gamma from a grey ramp ->
gamma.json) and ``--session DIR --poses N`` (calibration capture with a live preview).
"""
from __future__ import annotations

from contextlib import ExitStack
from dataclasses import dataclass, fields, replace

from pathlib import Path
from typing import Any

import typer
from rich.markup import escape

from fringe3d import __version__
from fringe3d.devices import DeviceSpec, open_camera, open_projector
from fringe3d.devices.acquire import (
    CaptureIncompleteError,
    CaptureTiming,
    capture_ramp,
    capture_sequence,
    check_exposure,
    configure_camera,
    measure_latency,
)
from fringe3d.devices.base import DeviceError
from fringe3d.io.pattern_folder import read_pattern_folder
from fringe3d.patterns.gamma import fit_gamma, save_gamma
from fringe3d.sim.virtual_devices import open_virtual_rig
from fringe3d.utils.console import (
    console,
    err_console,
    info,
    print_json,
    progress_bar,
    set_quiet,
)
from fringe3d.utils.jsonfile import write_json
from fringe3d.commands.checks import parse_exposures
from fringe3d.commands.output_options import overwrite_option
from fringe3d.commands.flag_words import in_flag_words
from fringe3d.utils.output_folder import open_output, open_output_file
from fringe3d.commands.capture_views import capture_views_mode, check_views_options

#: Exit code of a capture that stopped or lost frames (the folder is not marked complete).
EXIT_INCOMPLETE = 4


def _parse_roi(text: str | None):
    if text is None:
        return None
    try:
        roi = [int(v) for v in text.split(",")]
    except ValueError:
        roi = []
    if len(roi) != 4 or roi[2] <= 0 or roi[3] <= 0 or roi[0] < 0 or roi[1] < 0:
        raise ValueError(f"--roi is X,Y,WIDTH,HEIGHT in pixels, got {text!r}")
    return roi


def _parse_features(items: list[str] | None) -> list[tuple[str, str]]:
    out = []
    for it in items or []:
        name, sep, value = it.partition("=")
        if not sep or not name.strip():
            raise ValueError(f"--camera-feature is NAME=VALUE (a GenICam feature), got {it!r}")
        out.append((name.strip(), value.strip()))
    return out


def open_rig(projector: str, camera: str, patterns=None, features=None):
    """(projector, camera) from device specs; ``virtual`` devices come from the simulator."""

    ps, cs = DeviceSpec.parse(projector), DeviceSpec.parse(camera)
    if cs.backend == "virtual" and ps.backend != "virtual":
        raise ValueError("the virtual camera films the virtual projector's scene; use --projector virtual[:PRESET] "
                         "with --camera virtual")
    if ps.backend == "virtual":
        proj, cam = open_virtual_rig(ps, cs, patterns=patterns)
        if cam is None:
            cam = open_camera(cs, features=features)
        elif features:
            raise ValueError("the virtual camera has no GenICam features; drop --camera-feature")
        return proj, cam
    proj = open_projector(ps)
    try:
        cam = open_camera(cs, features=features)
    except BaseException:
        proj.close()
        raise
    return proj, cam


def register(app: typer.Typer) -> None:
    @app.command("capture")
    def capture(
        patterns: Path = typer.Argument(None, help="Pattern folder (PNGs + manifest.json from fringe3d patterns)."),
        output: Path = typer.Option(None, "-o", "--output", help="Capture folder to write (--gamma: the gamma.json; "
                                                                 "--latency: an optional latency.json)."),
        projector: str = typer.Option("window:0", help="Projector: window:SCREEN[?latency=S] or "
                                                       "virtual[:PRESET][?gamma=G&bitplanes=1]."),
        camera: str = typer.Option(None, help="Camera: pylon:SERIAL, genicam:PRODUCER.cti#SERIAL, opencv:INDEX or "
                                              "virtual[:PRESET][?scene=NAME&seed=N]."),
        sync: str = typer.Option("software", help="software (show, wait, trigger, retrieve) or hardware (the "
                                                  "projector's trigger output fires the camera)."),
        cycles: int = typer.Option(1, help="Repeat the pattern sequence N times (moving scenes)."),
        exposure: float = typer.Option(None, help="Camera exposure time (s)."),
        exposures: str = typer.Option(None, help="HDR exposure bracket: comma-separated exposure times (s), "
                                                 "shortest first; one pattern cycle per exposure (software sync; "
                                                 "decode fuses them per pixel). Costs one cycle of frames and "
                                                 "time per exposure."),
        gain: float = typer.Option(None, help="Camera gain (dB)."),
        pixel_format: str = typer.Option(None, "--pixel-format", help="Mono8, Mono10 or Mono12."),
        roi: str = typer.Option(None, help="Camera region of interest X,Y,WIDTH,HEIGHT (pixels)."),
        camera_feature: list[str] = typer.Option(None, "--camera-feature", help="Any GenICam feature NAME=VALUE, "
                                                 "set in order after opening (repeatable)."),
        frame_rate: float = typer.Option(None, "--frame-rate", help="Pattern rate (Hz) of a hardware-synced burst; "
                                         "default the projector's refresh rate (x 24 for packed bit-planes)."),
        settle: float = typer.Option(0.0, help="Software sync: seconds to wait after each show before triggering "
                                               "(the display-to-light delay measured with --latency)."),
        timeout: float = typer.Option(1.0, help="Seconds to wait for each frame before calling it dropped."),
        latency: bool = typer.Option(False, "--latency", help="Measure the display-to-camera delay by flashing "
                                                              "black/white, then exit."),
        gamma: bool = typer.Option(False, "--gamma", "--response",
                                   help="Project a grey ramp on a flat target, fit the projector's response (the "
                                        "monotone table and its gamma), write OUTPUT (gamma.json), then exit; "
                                        "fringe3d response keeps it with the rig."),
        levels: int = typer.Option(17, help="--gamma: number of grey levels in the ramp."),
        session: Path = typer.Option(None, help="Calibration capture: write DIR/pose_XX/ capture folders."),
        poses: int = typer.Option(10, help="--session: number of board poses to capture."),
        auto: bool = typer.Option(False, "--auto", help="--session: capture a pose when the board is found and "
                                                        "still for --still seconds (otherwise: press space)."),
        still: float = typer.Option(1.0, help="--session --auto: seconds the board must be still."),
        pose_timeout: float = typer.Option(60.0, "--pose-timeout", help="--session: give up when no pose is taken "
                                           "within this many seconds (camera time)."),
        preview: bool = typer.Option(True, "--preview/--no-preview", help="--session: show the live preview window."),
        cols: int = typer.Option(9, help="--session: board circles per row."),
        rows: int = typer.Option(9, help="--session: board rows."),
        spacing: float = typer.Option(None, help="--session: circle spacing (mm, recorded in session.json)."),
        views: int = typer.Option(None, "--views", help="Multi-view capture: N views, the stage moved before each; "
                                  "writes OUTPUT/view-NN capture folders and OUTPUT/poses.json."),
        stage: str = typer.Option(None, "--stage", help="--views: the stage, "
                                  "virtual[:STEP_DEG][?axis=X,Y,Z&point=X,Y,Z] (turns the virtual rig's scene) or "
                                  "grbl:PORT[?step=DEG&axis=A&baud=B&feed=F] (a GRBL controller's rotary axis); the "
                                  "step defaults to 360/N degrees."),
        stage_axis: Path = typer.Option(None, "--stage-axis", help="--views: the turntable axis (axis.json from "
                                        "fringe3d calibrate-axis) that turns stage angles into the poses of "
                                        "poses.json."),
        overwrite: bool = overwrite_option(),
        json_: bool = typer.Option(False, "--json", help="Print a JSON summary."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bars."),
    ) -> None:
        """Capture a pattern sequence with a projector and a camera into a capture folder.

        The folder is the standard capture folder (frames/, manifest.json, capture.json);
        capture.json says "complete": true only when every frame arrived, in order, once. Exit
        codes: 0 complete, 2 bad input (no such device, missing extra, patterns larger than the
        screen, ...), 4 frames dropped / duplicated or the capture was interrupted.

        Example: fringe3d capture pats -o cap --projector window:1 --camera pylon:40012345 --exposure 0.008

        Example: fringe3d capture pats -o cap --projector virtual:tiny --camera "virtual:tiny?scene=sphere"

        Example: fringe3d capture -o gamma.json --gamma --projector window:1 --camera pylon:40012345

        Example: fringe3d capture calib-pats --session session --poses 12 --auto --projector window:1 --camera pylon:

        Example: fringe3d capture pats -o scan --views 4 --stage virtual:20 --projector virtual:tiny --camera virtual
        """
        opts = dict(locals())
        try:
            run_capture(*(_group(cls, opts) for cls in (DeviceOptions, ModeOptions, RunOptions)))
        except (ValueError, FileNotFoundError) as e:  # printed here: device messages name extras in [] (no markup)
            err_console.print("[bold red]error:[/] " + escape(in_flag_words(str(e))))
            raise SystemExit(2) from None


@dataclass(frozen=True)
class DeviceOptions:
    """The ``fringe3d capture`` flags that open and set up the devices."""

    projector: str
    camera: Any  # str; None only until run_capture refuses it
    sync: str
    exposure: float | None
    exposures: Any  # the --exposures text; run_capture replaces it by the parsed bracket (s) or None
    gain: float | None
    pixel_format: str | None
    roi: str | None
    camera_feature: list[str] | None
    frame_rate: float | None
    settle: float
    timeout: float


@dataclass(frozen=True)
class ModeOptions:
    """The ``fringe3d capture`` flags that choose the mode (latency, gamma, calibration session)."""

    latency: bool
    gamma: bool
    levels: int
    session: Any  # Path or None
    poses: int
    auto: bool
    still: float
    pose_timeout: float
    preview: bool
    cols: int
    rows: int
    spacing: float
    views: int | None
    stage: str | None
    stage_axis: Any  # Path or None


@dataclass(frozen=True)
class RunOptions:
    """The ``fringe3d capture`` flags that say what to project, where to write and how to report."""

    patterns: Path | None
    output: Any  # Path or None
    cycles: int
    overwrite: bool
    json_: bool
    quiet: bool


def _group(cls, opts: dict):
    """The fields of dataclass ``cls`` taken from the command's ``opts`` (its parameters)."""
    return cls(**{f.name: opts[f.name] for f in fields(cls)})


def run_capture(dev: DeviceOptions, mode: ModeOptions, run: RunOptions) -> None:
    """The body of ``fringe3d capture`` (see its --help)."""
    camera, latency, gamma, session, patterns, output = dev.camera, mode.latency, mode.gamma, mode.session, \
        run.patterns, run.output
    set_quiet(run.quiet or run.json_)
    if camera is None:
        raise ValueError("--camera is required, e.g. --camera pylon:SERIAL or --camera virtual:tiny")
    features = _parse_features(dev.camera_feature)
    roi_v = _parse_roi(dev.roi)
    modes = sum(bool(m) for m in (latency, gamma, session is not None, mode.views is not None))
    if modes > 1:
        raise ValueError("--latency, --gamma, --session and --views are separate modes; give one")
    check_views_options(mode)
    ps = images = packed = None
    if not (latency or gamma):
        if patterns is None:
            raise ValueError("give the pattern folder to project (fringe3d patterns -o FOLDER writes one)")
        ps, images, packed = read_pattern_folder(patterns)
        if session is None and output is None:
            raise ValueError("-o/--output CAPTURE is required")
    if gamma and output is None:
        raise ValueError("--gamma needs -o gamma.json")
    if run.cycles < 1:
        raise ValueError(f"--cycles must be at least 1, got {run.cycles}")
    dev = replace(dev, exposures=parse_exposures(dev.exposures, "--exposures"))
    if dev.exposures is not None:
        clash = [f for f, on in (("--exposure", dev.exposure is not None), ("--cycles", run.cycles != 1),
                                 ("--sync hardware", dev.sync != "software"), ("--latency", latency),
                                 ("--gamma", gamma), ("--session", session is not None)) if on]
        if clash:
            raise ValueError(f"--exposures records one pattern cycle per exposure with software sync; drop "
                             f"{', '.join(clash)}")
    with ExitStack() as outputs:
        if latency or gamma:
            outputs.enter_context(open_output_file(output, overwrite=run.overwrite, inputs=[patterns]))
        elif session is not None:
            mode = replace(mode, session=outputs.enter_context(
                open_output(session, overwrite=run.overwrite, inputs=[patterns],
                            options={"camera": camera, "poses": mode.poses}, keep_unfinished=True)).path)
        else:
            opts = {"camera": camera, "cycles": run.cycles}
            if mode.views is not None:
                opts.update(views=mode.views, stage=mode.stage)
            run = replace(run, output=outputs.enter_context(
                open_output(output, overwrite=run.overwrite, inputs=[patterns, mode.stage_axis],
                            options=opts, keep_unfinished=True)).path)
        _run_with_devices((ps, images, packed), (roi_v, features), dev, mode, run)


def _run_with_devices(loaded: tuple, parsed: tuple, dev: DeviceOptions, mode: ModeOptions, run: RunOptions) -> None:
    """Open the rig and run the chosen mode, writing into the (guarded) output; ``loaded`` is the
    pattern folder's ``(patterns, images, packed)``, ``parsed`` the ``(roi, features)`` flags."""
    ps, images, packed = loaded
    roi_v, features = parsed
    projector, camera, sync, exposure, gain, pixel_format = (dev.projector, dev.camera, dev.sync, dev.exposure,
                                                             dev.gain, dev.pixel_format)
    frame_rate, settle, timeout = dev.frame_rate, dev.settle, dev.timeout
    latency, gamma, levels, session, poses, auto = (mode.latency, mode.gamma, mode.levels, mode.session, mode.poses,
                                                    mode.auto)
    still, pose_timeout, preview, cols, rows, spacing = (mode.still, mode.pose_timeout, mode.preview, mode.cols,
                                                         mode.rows, mode.spacing)
    patterns, output, cycles, json_, quiet = run.patterns, run.output, run.cycles, run.json_, run.quiet
    proj, cam = open_rig(projector, camera, patterns=ps, features=features)
    try:
        configure_camera(cam, pixel_format=pixel_format, roi=roi_v, exposure=None, gain=gain)
        planes = None
        show = images
        if packed is not None and sync == "hardware":
            show, planes = packed
        elif packed is not None:
            info("the pattern folder is packed into bit-planes; software sync shows the unpacked 1-bit frames")
        if exposure is not None:
            rate = frame_rate or (proj.refresh_rate * (24 if planes else 1) if sync == "hardware" else None)
            check_exposure(exposure, 1.0 / rate if rate else None,
                           f"{rate:g} Hz {'pattern rate' if sync == 'hardware' else 'frame rate'}" if rate else "")
            cam.exposure = exposure
        if latency:
            lat = measure_latency(proj, cam, timeout=timeout)
            if output is not None:
                write_json(output, lat, units={"latency": "s", "step": "s"})
            if json_:
                print_json(lat)
            else:
                console.print(f"display-to-camera delay {lat['latency'] * 1e3:.1f} ms (step {lat['step'] * 1e3:.1f} ms)"
                              f"; use --settle {lat['latency']:.4f}")
            return
        if gamma:
            lv, frames = capture_ramp(proj, cam, levels=levels, settle=settle, timeout=timeout)
            bd = {"Mono8": 8, "Mono10": 10, "Mono12": 12}.get(cam.pixel_format, 8)
            fit = fit_gamma(lv, frames, full_scale=2 ** bd - 1)
            fit.update(projector=proj.describe(), camera_device=cam.describe())
            save_gamma(output, fit)
            if json_:
                print_json({k: fit[k] for k in ("gamma", "rms_residual", "pixels")} | {"output": str(output)})
            else:
                console.print(f"projector gamma {fit['gamma']:.4f} (fit RMS {fit['rms_residual']:.4f}, "
                              f"{fit['pixels']} pixels); wrote {output}")
            return
        meta = {"fringe3d_version": _version(), "patterns_folder": str(patterns),
                "options": {"projector": projector, "camera": camera, "sync": sync, "cycles": cycles,
                            "settle": settle, "timeout": timeout, "frame_rate": frame_rate}}
        if session is not None:
            # heavy (the calibration package, scipy.optimize): only a board session needs it
            from fringe3d.devices.session import GrabTiming, PoseTrigger, SessionBoard, capture_session

            summary = capture_session(proj, cam, ps, images, session, poses,
                                      board=SessionBoard(cols=cols, rows=rows, spacing=spacing),
                                      trigger=PoseTrigger(auto=auto, preview=preview, still_seconds=still,
                                                          pose_timeout=pose_timeout),
                                      timing=GrabTiming(settle=settle, timeout=timeout), extra_meta=meta)
            if json_:
                print_json(summary)
            elif not quiet:
                console.print(f"captured {summary['poses']} poses into {session}; calibrate with "
                              f"fringe3d calibrate {session}")
            return
        if mode.views is not None:
            summary = capture_views_mode(proj, cam, (ps, show, planes), meta, dev, mode, run)
            if json_:
                print_json(summary)
            elif not quiet:
                console.print(f"captured {mode.views} views into {output} (view-NN folders, poses.json: "
                              f"{summary['poses_from']})")
            return
        bracket = dev.exposures
        total = len(ps) * (cycles if bracket is None else len(bracket))
        if bracket is not None:
            meta["options"]["exposures"] = bracket
            for t in bracket:  # each exposure must fit the frame period before anything is captured
                check_exposure(t, 1.0 / frame_rate if frame_rate else None, f"{frame_rate:g} Hz" if frame_rate else "")
        with progress_bar(f"capturing {total} frames", total, enabled=not (quiet or json_)) as advance:
            last = [0]

            def prog(n):
                advance(n - last[0])
                last[0] = n
            res = capture_sequence(proj, cam, ps, show, output, cycles=cycles, planes=planes, extra_meta=meta,
                                   progress=prog, timing=CaptureTiming(sync, settle, timeout, frame_rate, bracket))
    except CaptureIncompleteError as e:
        err_console.print(f"[bold red]capture incomplete:[/] {e}")
        raise SystemExit(EXIT_INCOMPLETE) from None
    except KeyboardInterrupt:
        err_console.print(f"[bold red]capture interrupted:[/] {output or session} is marked incomplete")
        raise SystemExit(EXIT_INCOMPLETE) from None
    except DeviceError as e:
        where = output or session
        err_console.print(f"[bold red]device error:[/] {e}" + (f"; {where} is marked incomplete" if where else ""))
        raise SystemExit(EXIT_INCOMPLETE) from None
    finally:
        cam.close()
        proj.close()
    summary = {"output": str(output), "frames": res.received, "complete": res.complete, "sync": sync,
               "camera": res.meta.get("camera_device", {}).get("model"), "cycles": cycles}
    if json_:
        print_json(summary)
    elif not quiet:
        console.print(f"captured {res.received} frames ({sync} sync) into {output}; capture.json marks it complete")


def _version() -> str:
    return __version__
