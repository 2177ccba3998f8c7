"""A wing-strain run from a point-map sequence to files (dissertation ch. 6): anchors ->
geodesic tracking (Eq. 6.9) -> Kirchhoff-Love bending strain (Eq. 6.10-6.21) -> CSV, VTK,
per-point arrays, PNG maps, GIF and a JSON summary. ``fringe3d strain`` is this function plus printing.

Frames are streamed: each 3D frame is read, tracked and written (its CSV rows, its ``.vtu``, its
rows of the per-point arrays) before the next few are read, so memory holds a bounded window of
frames whatever the sequence's length. Given the reference frame and every frame's anchors
(found up front from the textures), frames are independent: ``workers`` threads process several
at once (the numba kernels release the GIL) and the outputs are written in frame order, the
same bytes as one worker. The frame scheduler is injected (``frames``): the per-frame work is a
picklable :class:`~fringe3d.analyze.frame_task.StrainFrameTask`, so another scheduler may run
it in other processes (``fringe3d.cluster.strain_frames``: dask.distributed workers) while
this process still writes every file, in order.
"""
from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fringe3d.io.export_vtk import StrainCsvWriter, grid_triangles, strain_table, write_strain_frame, write_strain_pvd
from fringe3d.io.npy_stream import NpyFrameWriter, iter_npy_frames, read_npy_frame
from fringe3d.io.point_sequence import read_point_sequence
from fringe3d.io.strain_figures import (
    scatter_to_image,
    strain_animation,
    strain_map_png,
)
from fringe3d.utils.console import progress_bar
from fringe3d.utils.jsonfile import write_json
from fringe3d.utils.streamed_quantiles import streamed_median, streamed_percentile

from .anchors import (
    auto_anchors,
    check_anchor,
    fill_dot_holes,
    follow_anchors,
    parse_anchors,
    query_grid,
)
from .frame_task import StrainFrameTask
from .strain import TrackingSettings, WingFrame, wing_reference

#: Per-point arrays written to ``arrays/wing_K/NAME.npy``: (per-point shape, dtype) of each.
ARRAY_FIELDS = {"uv": ((2,), np.float64), "xyz": ((3,), np.float64), "E": ((2, 2), np.float64),
                "principal": ((2,), np.float64), "dominant": ((), np.float64), "residual": ((), np.float64),
                "ok": ((), np.bool_)}
#: Frames in flight per worker (read, being processed or waiting to be written in order).
FRAMES_PER_WORKER = 2


class _StrainImages:
    """The per-frame dominant-strain images (H, W) float, NaN off the wings, drawn on demand from
    the per-point arrays on disk (so neither the maps nor the GIF hold F frames of results)."""

    def __init__(self, folders: list[Path], shape, radius: int, frames: int):
        self.folders, self.shape, self.radius, self.frames = folders, shape, radius, frames

    def __len__(self) -> int:
        return self.frames

    def __getitem__(self, f: int) -> np.ndarray:
        if not 0 <= f < self.frames:
            raise IndexError(f)
        img = np.full(self.shape, np.nan)
        for d in self.folders:
            uv, dom, ok = (read_npy_frame(d / f"{n}.npy", f) for n in ("uv", "dominant", "ok"))
            part = scatter_to_image(uv[ok], dom[ok], self.shape, radius=self.radius)
            img = np.where(np.isfinite(part), part, img)
        return img


class _Subset:
    """Frames ``picks`` of a lazy image sequence, themselves drawn on demand."""

    def __init__(self, images, picks: list[int]):
        self.images, self.picks = images, picks

    def __len__(self) -> int:
        return len(self.picks)

    def __getitem__(self, i: int) -> np.ndarray:
        return self.images[self.picks[i]]


#: The GIF shows at most this many frames, evenly spaced: matplotlib's Pillow writer holds every
#: frame of an animation in memory until it is saved, so a long take's GIF is bounded this way
#: (the PNG maps and the VTU series hold every frame).
GIF_FRAMES = 300


def gif_frames(n: int, most: int | None = None) -> list[int]:
    """The frames the GIF shows: all of ``n`` when ``n <= most`` (default :data:`GIF_FRAMES`),
    else ``most`` evenly spaced ones, the first and the last included."""
    most = GIF_FRAMES if most is None else int(most)
    if n <= most:
        return list(range(n))
    return [int(f) for f in np.unique(np.round(np.linspace(0, n - 1, most)).astype(int))]


#: A frame scheduler: ``frames(task, n)`` yields ``(f, task(f))`` for f = 0 … n − 1, in order.
FrameScheduler = Callable[[StrainFrameTask, int], Iterator[tuple[int, list[WingFrame]]]]


def frames_in_order(task, n: int, workers: int = 1):
    """``(f, task(f))`` for f = 0 … n − 1 in order, ``task`` run on ``workers`` threads with at most
    ``FRAMES_PER_WORKER · workers`` frames in flight (bounded memory); an error in any task is
    raised at its turn, and the frames not yet started are dropped."""
    if workers <= 1:
        for f in range(n):
            yield f, task(f)
        return
    pool = ThreadPoolExecutor(max_workers=workers)
    try:
        pending: deque = deque()
        nxt = 0
        while nxt < n or pending:
            while nxt < n and len(pending) < FRAMES_PER_WORKER * workers:
                pending.append((nxt, pool.submit(task, nxt)))
                nxt += 1
            f, fut = pending.popleft()
            yield f, fut.result()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _ok_values(folders: list[Path], name: str, transform=None):
    """A callable giving, per frame and wing, the finite values of array ``name`` at ok points."""
    def values():
        for d in folders:
            for v, ok in zip(iter_npy_frames(d / f"{name}.npy"), iter_npy_frames(d / "ok.npy")):
                x = v[ok] if transform is None else transform(v[ok])
                yield x[np.isfinite(x)]
    return values


def frame_label(f: int, frame_rate: float | None) -> str:
    """``frame F`` and, with a frame rate (Hz), its time ``t = F / rate`` in ms."""
    return f"frame {f}" + (f", t = {1e3 * f / frame_rate:.4g} ms" if frame_rate else "")


def _run_tracking() -> TrackingSettings:
    """A strain run's default tracking: :class:`~fringe3d.analyze.strain.TrackingSettings` with the
    anchor-dot holes filled up to 8 px (a dark dot does not reconstruct)."""
    return TrackingSettings(fill_dots=8)


@dataclass(frozen=True)
class StrainSettings:
    """What a strain run (:func:`run_strain`) measures and how it tracks.

    Attributes
    ----------
    thickness : float
        Wing thickness h, mm (> 0; E = (h/2)·κ, Eq. 6.11). Default 0.1.
    step : int
        Spacing of the tracked grid of reference pixels, pixels (>= 1). Default 4.
    wings : int
        Number of wings, for ``anchors="auto"``. Default 1.
    reference : int
        Index of the undeformed reference frame. Default 0.
    tracking : TrackingSettings
        Fit window (odd, >= 3 px), geodesic method and marching window (px), anchor-dot filling
        (px) and search margin (:class:`~fringe3d.analyze.strain.TrackingSettings`); default
        ``TrackingSettings(fill_dots=8)``: a strain run fills dot holes up to 8 px.

    Examples
    --------
    >>> StrainSettings(step=6).tracking.fill_dots
    8
    """

    thickness: float = 0.1
    step: int = 4
    wings: int = 1
    reference: int = 0
    tracking: TrackingSettings = field(default_factory=_run_tracking)


def run_strain(sequence, anchors: str, out: Path, settings: StrainSettings | None = None, figures: bool = True,
               workers: int = 1, frames: FrameScheduler | None = None, frame_rate: float | None = None) -> dict:
    """Track a wing sequence and map its bending strain (Eq. 6.9-6.21): everything
    ``fringe3d strain`` does; returns the JSON summary. Validates all inputs before any file
    is written (``strain.csv``, ``vtk/frame_*.vtu`` + ``strain.pvd``, ``arrays/wing_K/*.npy`` (F, N, ...)
    per-point results, ``maps/strain_*.png``, ``strain.gif``, ``summary.json`` in ``out``, each
    atomically). Every file is written here, in frame order, whatever the scheduler.

    Parameters
    ----------
    sequence : str or Path
        Point-map sequence (:func:`fringe3d.io.point_sequence.read_point_sequence`: a folder of
        ``points_*.npy``, a .npy/.npz with ``points`` (F, H, W, 3) mm, or a zarr store).
    anchors : str
        ``"auto"`` (dark dots found in the reference texture) or ``"u1,v1,u2,v2[;...]"``, pixels,
        one group per wing (:func:`fringe3d.analyze.anchors.parse_anchors`).
    out : Path
        Output folder.
    settings : StrainSettings, optional
        Thickness (mm), grid step (px), wing count, reference frame and the tracking settings
        (default ``StrainSettings()``).
    figures : bool
        Write the strain maps (PNG) and the GIF animation.
    workers : int
        Frames processed at once on threads (the same output for any number).
    frames : FrameScheduler, optional
        Another frame scheduler (e.g. :func:`fringe3d.cluster.strain_frames.frames_on_dask`'s),
        given the :class:`~fringe3d.analyze.frame_task.StrainFrameTask` and the frame count; then
        ``workers`` must be 1.
    frame_rate : float, optional
        Rate of the 3D frames (Hz); the PVD time steps and figure titles are then in
        seconds (else frame numbers).

    Returns
    -------
    dict
        The summary also written to ``summary.json``: frame, wing and point counts, tracked
        fraction, median tracking residual (mm), 99th percentile of the dominant strain, the
        settings and the run time (s).
    """
    t0 = time.perf_counter()
    settings = settings if settings is not None else StrainSettings()
    thickness, step, wings, reference = settings.thickness, settings.step, settings.wings, settings.reference
    tracking = settings.tracking
    window, radius, fill_dots = tracking.window, tracking.radius, tracking.fill_dots
    if not (thickness > 0):
        raise ValueError(f"`thickness` must be > 0 mm; got {thickness}")
    if window < 3 or window % 2 == 0:
        raise ValueError(f"`window` must be an odd number of pixels ≥ 3; got {window}")
    if step < 1:
        raise ValueError(f"`step` must be ≥ 1 pixel; got {step}")
    if workers < 1:
        raise ValueError(f"`workers` must be ≥ 1; got {workers}")
    if frame_rate is not None and not frame_rate > 0:
        raise ValueError(f"`frame_rate` must be > 0 Hz; got {frame_rate}")
    if frames is not None and workers != 1:
        raise ValueError(f"`workers` {workers} (threads) runs the frames in this process; it cannot be combined "
                         "with another frame scheduler (Dask)")
    start = parse_anchors(anchors)
    seq = read_point_sequence(sequence)
    if not (0 <= reference < len(seq)):
        raise ValueError(f"`reference` {reference} is outside the sequence's {len(seq)} frames")
    if start is None:
        start = auto_anchors(seq, wings)
    ref = seq[reference]
    for a in start:
        filled = fill_dot_holes(ref, a, fill_dots) if fill_dots > 0 else ref
        for x in a:
            check_anchor(filled, x)
    per_frame = follow_anchors(seq.texture if seq.has_texture else None, len(seq), start)
    refs = []
    for w, a in enumerate(start):
        q = query_grid(ref, a, step, margin=window // 2)
        if len(q) == 0:
            raise ValueError(f"wing {w}: no surface pixels around the anchors to track")
        refs.append(wing_reference(ref, per_frame[reference, w], q, thickness, tracking))
    out = Path(out)
    nf = len(seq)
    folders = [out / "arrays" / f"wing_{w}" for w in range(len(refs))]
    offsets = np.cumsum([0] + [len(r.q) for r in refs])

    task = StrainFrameTask(str(Path(sequence).resolve()), reference, tuple(refs), per_frame, _seq=seq)
    schedule = frames if frames is not None else (lambda task, n: frames_in_order(task, n, workers))

    frame_files = []
    ok_count = total = 0
    with ExitStack() as stack, progress_bar("tracking + strain", total=nf * len(refs)) as advance:
        csv = stack.enter_context(StrainCsvWriter(out / "strain.csv"))
        arrays = [{name: stack.enter_context(NpyFrameWriter(d / f"{name}.npy", nf, (len(r.q),) + shape, dtype))
                   for name, (shape, dtype) in ARRAY_FIELDS.items()} for d, r in zip(folders, refs)]
        for f, results in schedule(task, nf):
            tables = []
            for w, r in enumerate(results):
                tab = strain_table(r.xyz, r.E, r.principal, r.dominant, r.uv, r.residual, r.ok)
                tables.append(tab)
                csv.append(tab, f, w)
                for name, writer in arrays[w].items():
                    writer.append(getattr(r, name))
                ok_count += int(np.count_nonzero(r.ok))
                total += r.ok.size
                advance()
            tri = np.concatenate([grid_triangles(rf.q, step, r.ok & np.isfinite(r.xyz).all(axis=-1)) + o
                                  for rf, r, o in zip(refs, results, offsets)])
            frame_files.append(write_strain_frame(out / "vtk" / f"frame_{f:05d}.vtu", np.vstack(tables), tri))
    write_strain_pvd(out / "strain.pvd", frame_files, frame_rate=frame_rate)
    p99 = streamed_percentile(_ok_values(folders, "dominant", np.abs), 99)
    if figures:
        vmax = p99 if ok_count else 1e-6
        images = _StrainImages(folders, seq.shape[:2], max(step // 2, 1), nf)
        for f in range(nf):
            strain_map_png(out / "maps" / f"strain_{f:05d}.png", images[f],
                           f"dominant bending strain, {frame_label(f, frame_rate)}", vmax)
        picks = gif_frames(nf)
        strain_animation(out / "strain.gif", _Subset(images, picks), [frame_label(f, frame_rate) for f in picks],
                         vmax)
    summary = {
        "frames": nf, "wings": len(refs), "points_per_wing": [int(len(r.q)) for r in refs],
        "tracked_fraction": ok_count / total if total else float("nan"),
        "median_residual_mm": streamed_median(_ok_values(folders, "residual")),
        "dominant_strain_p99": p99,
        "frame_rate_hz": frame_rate, "pvd_time_unit": "s" if frame_rate else "frame",
        "thickness_mm": thickness, "window_px": window, "step_px": step, "geodesic_window_px": 2 * radius + 1,
        "seconds": round(time.perf_counter() - t0, 2), "output": str(out),
    }
    write_json(out / "summary.json", summary, units={"median_residual_mm": "mm", "thickness_mm": "mm",
                                                     "dominant_strain_p99": "1 (strain)", "window_px": "px",
                                                     "frame_rate_hz": "Hz",
                                                     "step_px": "px", "geodesic_window_px": "px", "seconds": "s"})
    return summary
