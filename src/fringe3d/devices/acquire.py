"""The capture loop: patterns on the projector, frames from the camera, into a capture folder.

Sync modes (``sync``):

* ``"software"``: per frame, ``projector.show(image)`` (returns after the vsync'd swap) ->
  wait ``settle`` s (the measured display-to-light latency, ``fringe3d capture --latency``) -> software trigger ->
  retrieve the frame (``timeout`` s). A frame that does not arrive is reported missing.
* ``"hardware"``: the camera is armed on its trigger input (``Line1``) and the projector's
  trigger output (a DLP's trigger out, or a VSYNC tap) exposes it; per shown image the loop
  collects ``planes`` frames (1, or up to 24 for a packed bit-plane frame), places each by its
  camera timestamp in the burst (expected period ``1 / (refresh_rate * planes)``) and reports
  frames that did not come (missed trigger) or came twice.

After the loop the frames' camera ids and timestamps are checked: an id gap means frames were
lost in transport, a repeated id or a timestamp interval far from the expected one a duplicated
or missed frame; each problem names the frame (its index in projection order, pattern and
cycle).

The capture folder is the standard one (:mod:`fringe3d.io.capture`). ``capture.json`` is written
first with ``"complete": false``, each frame as it arrives (atomically), and ``capture.json``
last with ``"complete": true`` only when every frame is in and no frame was dropped or
duplicated: that last write is the completion marker. An interrupted capture (Ctrl-C, a device
error) keeps ``"complete": false`` with the reason, and :func:`fringe3d.io.capture.read_capture`
refuses it.
"""
from __future__ import annotations

import datetime as _dt
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from fringe3d.io.capture import CAPTURE_UNITS, FRAMES_DIR, META_NAME
from fringe3d.io.images import write_image
from fringe3d.patterns.bitplanes import PLANES_PER_FRAME
from fringe3d.patterns.manifest import MANIFEST_NAME, PatternSet
from fringe3d.utils.jsonfile import write_json
from fringe3d.utils.write_guard import guard_write

from .base import PIXEL_FORMATS, DeviceError, check_image_fits

SYNC_MODES = ("software", "hardware")
CAPTURE_FORMAT = "fringe3d-capture"


class CaptureIncompleteError(RuntimeError):
    """Frames were dropped or duplicated (or the capture stopped): the folder is not complete."""

    def __init__(self, message: str, result: CaptureResult | None = None):
        super().__init__(message)
        self.result = result


@dataclass
class CaptureResult:
    folder: Path
    expected: int
    received: int
    missing: list[int] = field(default_factory=list)
    duplicates: list[int] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)
    complete: bool = False
    meta: dict = field(default_factory=dict)


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def _frame_label(i: int, n_patterns: int, planes_per_show: int = 1) -> str:
    cycle, pat = divmod(i, n_patterns)
    return f"frame {i} (pattern {pat}, cycle {cycle})"


def check_exposure(exposure: float | None, frame_period: float | None, what: str) -> None:
    """``ValueError`` when the exposure does not fit the frame period."""
    if exposure is None or frame_period is None:
        return
    if not (math.isfinite(exposure) and exposure > 0):
        raise ValueError(f"exposure must be a positive time in seconds, got {exposure}")
    if exposure > frame_period * (1 + 1e-9):
        raise ValueError(f"exposure {exposure:g} s is longer than the frame period {frame_period:g} s ({what}); "
                         f"shorten the exposure or lower the frame rate")


def configure_camera(camera, *, exposure=None, gain=None, pixel_format=None, roi=None) -> None:
    """Apply the settings that are given (pixel format and ROI first, then exposure and gain)."""
    if pixel_format is not None:
        camera.pixel_format = pixel_format
    if roi is not None:
        camera.roi = tuple(int(v) for v in roi)
    if exposure is not None:
        camera.exposure = float(exposure)
    if gain is not None:
        camera.gain = float(gain)


def _bit_depth(camera) -> int | None:
    try:
        return PIXEL_FORMATS.get(camera.pixel_format)
    except Exception:
        return None


def _place_burst(frames, n: int, period: float | None):
    """Slots of a burst's frames by timestamp (expected spacing ``period``); sequential when the
    camera gives no timestamps. Returns (slots list[Frame|None] of length n, duplicate slots)."""
    slots: list = [None] * n
    dups: list[int] = []
    usable = period and len(frames) > 1 and any(f.timestamp for f in frames)
    for j, f in enumerate(frames):
        s = int(round((f.timestamp - frames[0].timestamp) / period)) if usable else j
        if s >= n or slots[s] is not None:
            dups.append(min(s, n - 1))
            continue
        slots[s] = f
    return slots, dups


@dataclass(frozen=True)
class CaptureTiming:
    """How the capture loop times the devices (:func:`capture_sequence`).

    Attributes
    ----------
    sync : str
        ``"software"`` (trigger after each shown image) or ``"hardware"`` (the projector's
        trigger output exposes the camera); see the module docstring.
    settle : float
        Software sync: seconds to wait after ``show`` before triggering (display-to-light latency).
    timeout : float
        Seconds to wait for each frame.
    frame_rate : float | None
        Expected frame rate (Hz) for the hardware burst checks; ``None``: the projector's refresh
        rate times the planes per image.
    exposures : sequence of float | None
        Software sync: an HDR bracket, the camera's exposure time (s) for each cycle, set before
        the cycle (the cycle count is then its length); ``capture.json`` gets ``exposures`` and
        every frame record its ``exposure``. ``None``: the configured exposure throughout.
    """

    sync: str = "software"
    settle: float = 0.0
    timeout: float = 1.0
    frame_rate: float | None = None
    exposures: Sequence[float] | None = None


def capture_sequence(projector, camera, patterns: PatternSet, images, folder, *, timing: CaptureTiming | None = None,
                     cycles: int = 1, planes: list[int] | None = None, extra_meta: dict | None = None,
                     progress=None) -> CaptureResult:
    """Capture ``cycles`` cycles of ``patterns`` into the capture folder ``folder``.

    ``timing.exposures`` (s, software sync): an HDR bracket, one cycle per exposure time, the
    camera's exposure set before each cycle (``cycles`` is then ``len(exposures)``);
    ``capture.json`` gets ``exposures`` and every frame record its ``exposure``.

    Parameters
    ----------
    projector : Projector
    camera : Camera
        Already configured (exposure, gain, pixel format, ROI: :func:`configure_camera`).
    patterns : PatternSet
        The manifest copied into the capture (one camera frame per pattern frame).
    images : sequence of (H, W) or (H, W, 3) uint8
        What the projector shows, in order. Unpacked: one image per pattern. Packed bit-planes:
        one RGB image per video frame, ``planes[j]`` patterns each (``sync="hardware"`` only).
    folder : path
    timing : CaptureTiming, optional
        Sync mode, settle and frame timeout (s), expected frame rate (Hz), exposure bracket (s);
        default :class:`CaptureTiming` ``()`` (software sync).
    cycles : int
        Repetitions of the sequence (moving scenes).
    planes : list of int, optional
        Patterns per shown image (packed bit-planes, hardware sync); default one each.
    extra_meta : dict, optional
        More ``capture.json`` fields (command line, provenance).
    progress : callable, optional
        Called with the number of frames received so far after each frame.

    Returns
    -------
    CaptureResult (``complete`` True).

    Raises
    ------
    ValueError
        Bad sync mode, cycles, or an image larger than the projector.
    CaptureIncompleteError
        Frames were missing or duplicated; the folder is written but not marked complete.
    """
    timing = timing or CaptureTiming()
    sync, settle, timeout, frame_rate, exposures = (timing.sync, timing.settle, timing.timeout, timing.frame_rate,
                                                    timing.exposures)
    if exposures is not None:
        if sync != "software":
            raise ValueError("exposures: an exposure bracket changes the exposure between cycles; use software sync")
        cycles = len(exposures)
    images, planes = _check_inputs(projector, patterns, images, planes, sync, cycles)
    n_pat = len(patterns)
    total = n_pat * cycles
    check = getattr(camera, "check_sequence", None)  # optional: a device that can vet the whole sequence first
    if callable(check):
        check(total)
    folder = Path(folder)
    fdir = folder / FRAMES_DIR
    fdir.mkdir(parents=True, exist_ok=True)
    for stale in fdir.glob("*"):
        if stale.is_file():
            guard_write(stale).unlink()
    packed = max(planes) > 1
    if packed and callable(getattr(projector, "configure_bitplanes", None)):
        projector.configure_bitplanes(planes)
    plane_rate = frame_rate or (projector.refresh_rate * (PLANES_PER_FRAME if packed else 1))
    period = 1.0 / plane_rate if plane_rate else None
    camera.trigger_mode = sync
    bd = _bit_depth(camera)
    meta = _initial_meta(camera, projector, total, cycles, sync, settle, timeout, period, bd, planes)
    meta.update(extra_meta or {})
    if exposures is not None:
        meta["exposures"] = [float(e) for e in exposures]
    patterns.save(folder / MANIFEST_NAME)
    write_json(folder / META_NAME, meta, units=CAPTURE_UNITS)

    records: list[dict | None] = [None] * total
    missing: list[int] = []
    dups: list[int] = []
    shape = None
    received = 0
    try:
        camera.start()
        for c in range(cycles):
            if exposures is not None:
                camera.exposure = float(exposures[c])
            base = c * n_pat
            first = 0
            for j, img in enumerate(images):
                shown = projector.show(img)
                idx = [base + first + p for p in range(planes[j])]
                first += planes[j]
                slots, burst_dups = _grab_slots(camera, sync, planes[j], settle, timeout, period)
                for s in burst_dups:
                    dups.append(idx[s])
                for s, fr in enumerate(slots):
                    i = idx[s]
                    if fr is None:
                        missing.append(i)
                        continue
                    img_c = np.asarray(fr.image)
                    if shape is None:
                        shape = img_c.shape
                    elif img_c.shape != shape:
                        raise DeviceError(f"{_frame_label(i, n_pat)} is {img_c.shape[1]}x{img_c.shape[0]} but "
                                          f"the first frame was {shape[1]}x{shape[0]}")
                    write_image(fdir / f"{i:05d}.png", img_c)
                    records[i] = {"index": i, "pattern": i % n_pat, "cycle": i // n_pat, "frame_id": int(fr.frame_id),
                                  "timestamp": float(fr.timestamp), "host_time": float(fr.host_time),
                                  "shown_at": float(shown)}
                    if exposures is not None:
                        records[i]["exposure"] = float(exposures[c])  # type: ignore[index]
                    received += 1
                    if progress is not None:
                        progress(received)
        camera.stop()
    except BaseException as e:  # interrupted: keep the folder marked incomplete, say why
        try:
            camera.stop()
        except Exception:
            pass
        meta.update(status="interrupted", interrupted=f"{type(e).__name__}: {e}" if str(e) else type(e).__name__,
                    finished=_now(), frames_received=received, frames=[r for r in records if r is not None])
        write_json(folder / META_NAME, meta, units=CAPTURE_UNITS)
        raise
    problems = _sequence_problems(records, missing, dups, n_pat, period if sync == "hardware" else None, timeout)
    complete = not problems and received == total
    meta.update(status="complete" if complete else "incomplete", finished=_now(), frames_received=received,
                frames=[r for r in records if r is not None], missing_frames=sorted(missing),
                duplicate_frames=sorted(set(dups)), problems=problems)
    _finish_meta(meta, records, shape, period if sync == "hardware" else None, frame_rate, bd)
    result = CaptureResult(folder=folder, expected=total, received=received, missing=sorted(missing),
                           duplicates=sorted(set(dups)), problems=problems, complete=complete, meta=meta)
    if complete:
        meta["complete"] = True
        write_json(folder / META_NAME, meta, units=CAPTURE_UNITS)  # the completion marker: written last
        return result
    write_json(folder / META_NAME, meta, units=CAPTURE_UNITS)
    raise CaptureIncompleteError(f"capture {folder} is incomplete ({received} of {total} frames): "
                                 + "; ".join(problems), result)


def _check_records(records, n_pat: int, period: float | None, dups: list[int]) -> list[str]:
    """Frame-id gaps / repeats and (hardware sync) timestamp intervals off the expected period."""
    out = []
    prev = None
    for r in records:
        if r is None:
            continue
        if prev is not None:
            gap = r["index"] - prev["index"]
            did = r["frame_id"] - prev["frame_id"]
            if did == 0:
                dups.append(r["index"])
                out.append(f"{_frame_label(r['index'], n_pat)} repeats camera frame id {r['frame_id']} of "
                           f"{_frame_label(prev['index'], n_pat)} (duplicated)")
            elif did < 0:
                pass  # the camera's counter wrapped or restarted
            elif did > gap:
                out.append(f"{_frame_label(r['index'], n_pat)}: camera frame id jumped by {did} after "
                           f"{_frame_label(prev['index'], n_pat)} ({did - gap} frame(s) lost in transport)")
            if period and (r["timestamp"] or prev["timestamp"]):
                dt = r["timestamp"] - prev["timestamp"]
                if abs(dt - gap * period) > 0.25 * period:
                    out.append(f"{_frame_label(r['index'], n_pat)}: timestamp {dt * 1e3:.3f} ms after "
                               f"{_frame_label(prev['index'], n_pat)}, expected {gap * period * 1e3:.3f} ms "
                               f"(off the frame period: a missed or extra trigger)")
        prev = r
    return out


# ----------------------------------------------------------------------------- helpers
def grab_mean(projector, camera, image, settle: float, timeout: float) -> tuple[np.ndarray, float]:
    """Show ``image``, wait ``settle`` s, trigger, and return (frame as float64, its mean)."""
    projector.show(image)
    if settle > 0:
        time.sleep(settle)
    camera.trigger()
    fr = camera.grab(timeout)
    img = np.asarray(fr.image, float)
    return img, float(img.mean())


def grey_ramp(levels: int = 17) -> np.ndarray:
    """``levels`` grey values from 0 to 255 inclusive, evenly spaced (uint8)."""
    if levels < 3:
        raise ValueError(f"a grey ramp needs at least 3 levels, got {levels}")
    return np.unique(np.rint(np.linspace(0, 255, levels)).astype(np.uint8))


def capture_ramp(projector, camera, levels: int = 17, settle: float = 0.0, timeout: float = 1.0,
                 repeats: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Show full-screen grey levels (software sync) and return (levels (L,), frames (L, H, W) float64),
    each frame the mean of ``repeats`` exposures."""
    values = grey_ramp(levels)
    camera.trigger_mode = "software"
    camera.start()
    frames = []
    try:
        for v in values:
            img = np.full((projector.height, projector.width), v, np.uint8)
            acc = None
            for _ in range(repeats):
                f, _ = grab_mean(projector, camera, img, settle, timeout)
                acc = f if acc is None else acc + f
            frames.append(acc / repeats)
    finally:
        camera.stop()
    return values, np.stack(frames)


def measure_latency(projector, camera, max_delay: float = 0.25, step: float | None = None,
                    timeout: float = 1.0) -> dict:
    """Display-to-camera delay by flashing black/white (software sync).

    For delays ``d = 0, step, 2 step, ...`` after ``show`` returns: show black, then white, wait
    ``d``, trigger. The latency is the first ``d`` whose frame is brighter than halfway between
    the black and the white frame. ``step`` defaults to a quarter of the refresh period.
    """
    step = step or 0.25 / projector.refresh_rate
    black = np.zeros((projector.height, projector.width), np.uint8)
    white = np.full_like(black, 255)
    camera.trigger_mode = "software"
    camera.start()
    try:
        _, lo = grab_mean(projector, camera, black, max_delay, timeout)
        _, hi = grab_mean(projector, camera, white, max_delay, timeout)
        if hi - lo < 1e-6 * max(1.0, abs(hi)):
            raise DeviceError(f"the camera does not see the projector: black and white frames have the same mean "
                              f"({lo:.1f}); point the camera at the projected area")
        d = 0.0
        while d <= max_delay + 1e-12:
            grab_mean(projector, camera, black, max_delay, timeout)
            _, m = grab_mean(projector, camera, white, d, timeout)
            if m > 0.5 * (lo + hi):
                return {"latency": d, "step": step, "black_mean": lo, "white_mean": hi,
                        "show_latency": float(getattr(projector, "latency", 0.0))}
            d += step
    finally:
        camera.stop()
    raise DeviceError(f"the white flash never showed within {max_delay:g} s of show(); the display-to-camera delay "
                      f"is longer, or the camera is not triggered by software")


def _grab_slots(camera, sync: str, n_planes: int, settle: float, timeout: float, period: float | None):
    """The camera frames for one shown image, one slot per pattern (None: not received), and the
    slots that received two frames. Software sync: wait ``settle``, trigger, grab one frame.
    Hardware sync: grab the burst of ``n_planes`` frames the projector triggered and place them
    by timestamp (:func:`_place_burst`)."""
    if sync == "software":
        if settle > 0:
            time.sleep(settle)
        camera.trigger()
        try:
            return [camera.grab(timeout)], []
        except TimeoutError:
            return [None], []
    got = []
    for _ in range(n_planes):
        try:
            got.append(camera.grab(timeout))
        except TimeoutError:
            break
    return _place_burst(got, n_planes, period)


def _sequence_problems(records, missing, dups, n_pat: int, period: float | None, timeout: float) -> list[str]:
    """Every reason the sequence is incomplete, naming the frames: duplicated, out of period, dropped."""
    problems = [f"{_frame_label(i, n_pat)} was received twice (duplicated)" for i in sorted(set(dups))]
    problems += _check_records(records, n_pat, period, dups)
    problems += [f"{_frame_label(i, n_pat)} was not received (dropped: no frame within {timeout:g} s "
                 f"of its trigger)" for i in missing]
    return problems


def _finish_meta(meta: dict, records, shape, period: float | None, frame_rate: float | None, bit_depth) -> None:
    """Camera size, measured and nominal frame rates and the bit depth into ``capture.json``."""
    if shape is not None:
        meta["camera"] = [int(shape[1]), int(shape[0])]
    shown = [r["shown_at"] for r in records if r is not None]
    if len(shown) > 1 and shown[-1] > shown[0]:
        meta["sync"]["measured_frame_rate"] = (len(shown) - 1) / (shown[-1] - shown[0])  # host clock
    if period:
        meta["frame_rate"] = 1.0 / period
    elif frame_rate:
        meta["frame_rate"] = float(frame_rate)
    if bit_depth is None and shape is not None:
        meta["bit_depth"] = 8


def _check_inputs(projector, patterns: PatternSet, images, planes, sync: str, cycles: int):
    """``(images, planes)`` checked against the manifest, the sync mode and the screen size."""
    if sync not in SYNC_MODES:
        raise ValueError(f"sync mode {sync!r} is not one of {', '.join(SYNC_MODES)}")
    if cycles < 1:
        raise ValueError(f"`cycles` must be >= 1, got {cycles}")
    images = list(images)
    n_pat = len(patterns)
    planes = list(planes) if planes is not None else [1] * len(images)
    if sum(planes) != n_pat or len(planes) != len(images):
        raise ValueError(f"{len(images)} projector images carrying {sum(planes)} patterns do not match the "
                         f"manifest's {n_pat} frames")
    if max(planes) > 1 and sync != "hardware":
        raise ValueError("packed bit-plane frames are shown as several patterns per video frame; only the "
                         "projector's trigger output can time them: use `sync` hardware")
    if patterns.width > projector.width or patterns.height > projector.height:
        raise ValueError(f"the patterns are {patterns.width}x{patterns.height} but the projector is "
                         f"{projector.width}x{projector.height}; patterns larger than the screen cannot be shown 1:1")
    return [check_image_fits(im, projector.width, projector.height) for im in images], planes


def _initial_meta(camera, projector, total: int, cycles: int, sync: str, settle: float, timeout: float,
                  period: float | None, bit_depth, planes: list[int]) -> dict:
    """``capture.json`` as written before the first frame: marked incomplete, devices and sync."""
    meta = {"format": CAPTURE_FORMAT, "complete": False, "status": "capturing", "started": _now(),
            "frames_expected": total, "cycles": cycles, "camera_device": camera.describe(),
            "projector": projector.describe(),
            "sync": {"mode": sync, "latency": float(getattr(projector, "latency", 0.0)), "settle": settle,
                     "timeout": timeout, "expected_period": period if sync == "hardware" else None}}
    if bit_depth:
        meta["bit_depth"] = bit_depth
    if max(planes) > 1:
        meta["bitplanes"] = {"planes_per_video_frame": planes}
    return meta
