"""High-speed sequences: many captured frames -> one 3D frame per pattern cycle or sliding window.

A capture of ``F`` frames repeats the manifest's cycle of ``n`` patterns. Two ways to cut it:

* ``mode="cycle"``: frames ``[c*n, (c+1)*n)`` -> 3D frame ``c`` (F/n 3D frames);
* ``mode="window"``: every ``step`` frames a window of ``n`` consecutive frames (any phase of
  the cycle) -> one 3D frame, ``(F - n)//step + 1`` 3D frames; the window's frames are
  reordered into manifest order, which is what superfast systems do to reach one 3D frame per
  captured frame.

Each 3D frame is decoded by :func:`fringe3d.decode.decode` and triangulated
(:func:`fringe3d.reconstruct.depth.points_from_decoded`); a single-direction 3-step manifest
unwrapped by the geometric constraint takes the fused :class:`FastThreeStep` kernel instead.
Outputs: a resumable zarr store (:class:`fringe3d.io.store.PointMapStore`) and/or one PLY per
3D frame; an interrupted run picks up where it stopped.
"""
from __future__ import annotations

import contextlib
import dataclasses
import os
from collections import deque
import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Iterator, NamedTuple

import numba
import numpy as np

from fringe3d.decode.context import phase_groups
from fringe3d.decode.method_plans import plan_for_method  # noqa: F401  (re-exported)
from fringe3d.decode.method_plans import with_method as plans_with_method
from fringe3d.decode.decoder import decode
from fringe3d.decode.edges import INVALID, oblique_factor
from fringe3d.decode.options import DecodeOptions
from fringe3d.patterns.method_registry import method_facts
from fringe3d.decode.plan_checks import check_plans
from fringe3d.decode.texture import as_fraction, fringe_texture
from fringe3d.gpu.runtime import check_backend
from fringe3d.io.capture import list_frame_files
from fringe3d.io.images import read_image
from fringe3d.io.ply_standard import write_measurement_ply
from fringe3d.io.store import LAYOUTS, PointMapStore
from fringe3d.optics.rays import camera_shape, projector_fringe_coordinate
from fringe3d.optics.rig import Rig
from fringe3d.patterns.conventions import w_range, w_to_phase
from fringe3d.patterns.manifest import PatternSet
from fringe3d.phase.quality import default_min_modulation
from fringe3d.reconstruct.depth import EmptyMaskError, points_from_decoded
from fringe3d.reconstruct.fast_quality import fast_quality
from fringe3d.reconstruct.triangulate import FastThreeStep, ThreeStepFields, Triangulator
from fringe3d.reconstruct.uncertainty import point_sigma
from fringe3d.unwrap.geometric import cached_minimum_phase, check_wrap_around
from fringe3d.utils.console import progress_bar
from fringe3d.utils.warning_types import ReconstructionWarning

STORE_NAME = "points.zarr"
PLY_DIR = "ply"

# ----------------------------------------------------------------------------- plans
def with_method(ps: PatternSet, method: str | None) -> PatternSet:
    """:func:`fringe3d.decode.method_plans.with_method`, keeping only the directions that
    triangulate: those with phase frames, and for a code method (``gray_code_only``, ...) those
    with code frames; ``ValueError`` when the manifest has none."""
    if method is None:
        return ps
    code = method_facts(method).code_only
    dirs = [d for d in ps.directions() if ps.groups(direction=d, role="phase") or
            (code and ps.indices(role="code", direction=d))]
    if not dirs:
        raise ValueError(f"the manifest ({ps.name or 'unnamed set'}) has no phase frames"
                         + (" and no code frames" if code else "") + "; nothing to reconstruct")
    chosen = plans_with_method(ps, method)
    return dataclasses.replace(chosen, plans=tuple(p for p in chosen.plans if p.direction in dirs))


# ----------------------------------------------------------------------------- windows
def window_starts(n_frames: int, cycle: int, mode: str = "cycle", step: int | None = None) -> list[int]:
    """First frame of each 3D frame's window (see the module docstring)."""
    if cycle <= 0:
        raise ValueError("the manifest lists no frames")
    if n_frames < cycle:
        raise ValueError(f"the capture has {n_frames} frames, fewer than one cycle of the manifest's {cycle}")
    if mode == "cycle":
        if n_frames % cycle:
            raise ValueError(f"{n_frames} frames are not a whole number of {cycle}-frame cycles")
        return list(range(0, n_frames, cycle))
    if mode == "window":
        step = 1 if step is None else int(step)
        if step < 1:
            raise ValueError(f"window step must be >= 1 frame, got {step}")
        return list(range(0, n_frames - cycle + 1, step))
    raise ValueError(f"unknown sequence mode {mode!r}; expected 'cycle' or 'window'")


def window_index(start: int, cycle: int) -> np.ndarray:
    """Frame indices of the window starting at ``start``, in manifest order: pattern ``p`` is
    the frame ``f`` in ``[start, start + cycle)`` with ``f % cycle == p``."""
    f = np.arange(start, start + cycle)
    out = np.empty(cycle, np.int64)
    out[f % cycle] = f
    return out


# ----------------------------------------------------------------------------- one 3D frame
class Cycle(NamedTuple):
    """One reconstructed cycle: ``points`` (H, W, 3) float32 mm (NaN invalid; None when not
    asked for), ``texture`` (H, W) float32 in [0, 1] (None when not asked for), ``quality`` (H, W) uint8 bits
    (:mod:`fringe3d.decode.edges`; 0 = kept), ``sigma_xyz`` (H, W, 3) float32 mm predicted
    standard deviations (or None), on the fused path ``depth`` (H, W) float32: the ray
    parameter ``s`` of every point (``points = ray_points(O, D, depth)``; None elsewhere), and
    ``sigma_z`` (H, W) float32 mm, ``sigma_xyz``'s z (or None)."""

    points: np.ndarray | None
    texture: np.ndarray | None
    quality: np.ndarray
    sigma_xyz: np.ndarray | None
    depth: np.ndarray | None = None
    sigma_z: np.ndarray | None = None


class FrameReconstructor:
    """Turns one cycle of frames (manifest order) into an ``(H, W, 3)`` float32 point map.

    Built once per rig and manifest: the minimum phase map and ray coefficients are computed
    once. ``fast=True`` takes the fused :class:`FastThreeStep` kernel when the manifest is one
    3-step direction unwrapped by ``"geometric"`` and the projector has no distortion (it masks by
    modulation, then the edge and mixed-pixel tests of :mod:`fringe3d.reconstruct.fast_quality`;
    saturation is not checked on that path).

    ``backend="cuda"`` runs the per-pixel kernels on a CUDA device (:mod:`fringe3d.gpu`): the
    fused kernel on the fused path, the fused three-frequency kernel on the decode path
    (``DecodeOptions.backend``); the quality tests, texture and everything else stay on the CPU,
    so the results equal the CPU backend's to float rounding.

    The plans are checked first (:func:`fringe3d.decode.plan_checks.check_plans`): a geometric
    method without ``options.z_min`` raises ``MissingGeometryError``, a wrapped or relative
    phase (method ``none``, ``spatial``) ``RelativePhaseError`` unless ``allow_relative``, which
    triangulates it with a :class:`~fringe3d.utils.warning_types.ReconstructionWarning` and
    lists its directions in :attr:`relative`.
    """

    def __init__(self, patterns: PatternSet, rig: Rig, options: DecodeOptions | None = None,
                 triangulation: str = "auto", fast: bool = True, backend: str = "cpu",
                 allow_relative: bool = False):
        self.patterns = patterns
        self.rig = rig
        self.backend = check_backend(backend)
        self.options = dataclasses.replace(options or DecodeOptions(), backend=self.backend)
        self.relative = check_plans(patterns, rig, self.options.z_min, allow_relative=allow_relative)
        if self.relative:
            warnings.warn(f"triangulating the wrapped or relative phase of direction(s) {list(self.relative)} "
                          "(allow_relative): the 3D is off by an unknown number of fringe periods in depth",
                          ReconstructionWarning, stacklevel=2)
        self.z_min = self.options.z_min
        self.triangulation = triangulation
        self._range_checked = False
        self.fast = self._fast_path() if fast else None

    @property
    def store_layout(self) -> str:
        """The point store layout that holds this reconstruction exactly: ``"ray_depth"`` on the
        fused path (it gives each point's ray parameter), ``"xyz"`` otherwise."""
        return "ray_depth" if self.fast is not None else "xyz"

    @property
    def rays(self) -> tuple[np.ndarray, np.ndarray]:
        """``(O (3,), D_planes (3, H, W))`` of the fused path's camera rays."""
        if self.fast is None:
            raise ValueError("only the fused 3-step path reconstructs along stored camera rays")
        return self.fast.tri.O, self.fast.tri.D_planes

    @property
    def path(self) -> str:
        return "fused 3-step + geometric kernel" if self.fast is not None else "decode + triangulate"

    def _fast_path(self):
        ps = self.patterns
        plans = ps.plans
        if len(plans) != 1 or plans[0].method != "geometric" or self.z_min is None or self.rig.telecentric:
            return None
        if self.rig.projector.dist.any():
            return None
        groups = phase_groups(ps, plans[0].direction)
        if len(groups) != 1 or len(groups[0].indices) != 3 or len(ps) != 3:
            return None
        g = groups[0]
        mp = cached_minimum_phase(self.rig, self.z_min, g.period, g.angle)
        self._fast_index = np.asarray(g.indices, np.int64)
        self._fast_shifts = g.shifts
        wr = plans[0].options.get("w_range")
        lo, hi = (float(wr[0]), float(wr[1])) if wr is not None else w_range(g.angle, ps.width, ps.height)
        f = oblique_factor(g.angle)  # a pixel's w-extent, as the decode path's (fringe3d.decode.assess)
        self._fast_extent = (lo - 0.5 * f, hi + 0.5 * f)
        self._fast_min_mod = self.options.min_modulation
        return FastThreeStep(Triangulator(self.rig, g.angle, warn_distortion=False), mp, g.shifts,
                             min_modulation=0.0, backend=self.backend)

    def __call__(self, frames: np.ndarray, with_texture: bool = False):
        """Points ``(H, W, 3)`` float32 (and the texture ``(H, W)`` float32 in [0, 1] if asked)."""
        c = self.reconstruct(frames, uncertainty=False)
        return (c.points, c.texture) if with_texture else c.points

    def depths(self, cycles: list[np.ndarray]) -> list | None:
        """On the CUDA fused path, the ray parameters (:meth:`FastThreeStep.depth`) of several
        cycles (each (n, H, W), manifest order) in one batched launch, for :meth:`reconstruct`'s
        ``depth``; None elsewhere (each cycle is then computed on its own)."""
        if self.fast is None or self.backend != "cuda" or len(cycles) < 2:
            return None
        self._set_min_modulation(cycles[0])
        return list(self.fast.depth(np.stack(cycles), index=self._fast_index))

    def _set_min_modulation(self, frames: np.ndarray) -> None:
        """The fused path's modulation threshold for ``frames`` (default: from their bit depth)."""
        assert self.fast is not None
        mm = self._fast_min_mod
        self.fast.min_mod2 = (default_min_modulation(frames, self.options.bit_depth) if mm is None else mm) ** 2

    def reconstruct(self, frames: np.ndarray, uncertainty: bool | str = True, points: bool = True,
                    texture: bool = True, depth: np.ndarray | None = None) -> Cycle:
        """One cycle (manifest order) -> :class:`Cycle`: points, texture, quality map (OR of the
        directions' bits, :mod:`fringe3d.decode.edges`) and, with ``uncertainty``, ``sigma_xyz``
        and ``sigma_z`` (:mod:`fringe3d.reconstruct.uncertainty`; ``"z"``: on the fused path
        ``sigma_z`` alone). Both paths mask edge and mixed pixels unless ``options.edge_mask``
        is False. ``points=False`` leaves ``points`` None on the fused path (its ``depth`` holds
        them), ``texture=False`` leaves ``texture`` None there. ``depth``: the fused kernel's ray
        parameters for these frames, already computed (:meth:`depths`)."""
        if self.fast is not None:
            return self._reconstruct_fused(frames, uncertainty, points, texture, depth)
        dec = decode(frames, self.patterns, rig=self.rig, options=self.options)
        pts = points_from_decoded(dec, self.rig, method=self.triangulation)
        tex = np.asarray(dec.texture, np.float32)  # a fraction of full scale already (fringe3d.decode.texture)
        quality = np.zeros(pts.shape[:2], np.uint8)
        for q in dec.quality.values():
            quality |= q
        quality[~np.isfinite(pts[..., 0]) & (quality == 0)] |= INVALID  # e.g. behind the camera
        sigma = point_sigma(dec, self.rig, method=self.triangulation) if uncertainty else None
        return Cycle(pts, tex, quality, sigma, sigma_z=None if sigma is None else np.ascontiguousarray(sigma[..., 2]))

    def _reconstruct_fused(self, frames: np.ndarray, uncertainty: bool | str, points: bool, texture: bool,
                           depth: np.ndarray | None) -> Cycle:
        """:meth:`reconstruct` on the fused path: one kernel pass gives the ray parameters and,
        where the quality tests, sigma_z or the texture need them, ``w``, ``A`` and ``B``."""
        fast = self.fast
        assert fast is not None
        if depth is not None:  # computed elsewhere (the CUDA batch): w, A, B are recomputed
            fields = ThreeStepFields(depth)
        else:
            self._set_min_modulation(frames)
            if self.backend == "cpu" and (self.options.edge_mask or uncertainty or texture):
                fields = fast.depth_fields(frames, self._fast_index)
            else:
                fields = ThreeStepFields(fast.depth(frames, index=self._fast_index))
        depth = fields.depth
        if not self._range_checked:  # once: the depth-range warning the decode path gives
            self._check_range(depth)
        fq = fast_quality(fast, frames, self._fast_index, self._fast_shifts, fields, self._fast_extent,
                          self.options, uncertainty)
        tex = None
        if texture:  # A + B as decode's; the kernel or the quality tests already have them
            tex = (as_fraction(np.add(fq.average, fq.modulation, dtype=np.float32), frames, self.options.bit_depth)
                   if fq.average is not None and fq.modulation is not None else
                   fringe_texture(frames, self._fast_shifts, self._fast_index, self.options.bit_depth))
        pts = fast.ray_points(depth) if points else None
        return Cycle(pts, tex, fq.quality, fq.sigma_xyz, depth, fq.sigma_z)

    def _check_range(self, depth: np.ndarray) -> None:
        """The depth-range warning of the decode path (:func:`fringe3d.unwrap.geometric.
        check_wrap_around`) from the points of ``depth`` before the edge tests mask any (an
        empty mask is left to :func:`fast_quality`)."""
        assert self.fast is not None
        mp = self.fast.mp
        valid = np.isfinite(depth)
        if not valid.any():
            return
        X = np.where(valid[..., None], self.fast.ray_points(depth), 0.0).astype(np.float64)
        w = projector_fringe_coordinate(self.rig, X, mp.angle)
        check_wrap_around(np.where(valid, w_to_phase(w, mp.period, scale_first=True), np.nan), mp, valid)
        self._range_checked = True


def reconstruct_window(rec: FrameReconstructor, frames: np.ndarray, ply: bool, layout: str | None,
                       quality: bool, depth: np.ndarray | None = None) -> tuple[Cycle, bool]:
    """One window (manifest order) for a sequence's outputs: ``(cycle, empty)``.

    ``ply`` asks for points and texture, ``layout`` (the store's, or None) for the points
    (``"xyz"``) or only the ray parameters (``"ray_depth"``), ``quality`` for the quality map
    and ``sigma_z``, ``depth`` for the fused kernel's ray parameters already computed
    (:meth:`FrameReconstructor.depths`). A window whose phase mask is empty gives an all-NaN,
    all-INVALID cycle and ``empty = True``.
    """
    want_points = ply or layout == "xyz"
    try:
        return rec.reconstruct(frames, uncertainty="z" if quality else False, points=want_points, texture=ply,
                               depth=depth), False
    except EmptyMaskError:
        pass
    H, W = frames.shape[1:]
    nan = np.full((H, W), np.nan, np.float32)
    return Cycle(np.full((H, W, 3), np.nan, np.float32) if want_points else None, None,
                 np.full((H, W), INVALID, np.uint8), None, nan if rec.fast is not None else None), True


def reconstructed_windows(rec: FrameReconstructor, frames, starts, ks: list[int], ply: bool, layout: str | None,
                          quality: bool) -> Iterator[tuple[int, Cycle, bool]]:
    """``(k, cycle, empty)`` of each 3D frame ``k`` of ``ks`` (:func:`reconstruct_window`), its
    window read from ``frames`` (F, H, W) at ``starts[k]``; on the CUDA fused path the ray
    parameters of all of ``ks`` come from one batched launch (:meth:`FrameReconstructor.depths`).
    The one per-frame loop of the serial and the Dask paths."""
    n = len(rec.patterns)
    cycles = [np.ascontiguousarray(frames[window_index(starts[k], n)]) for k in ks]
    depths = rec.depths(cycles)
    for i, (k, cycle_frames) in enumerate(zip(ks, cycles)):
        cyc, was_empty = reconstruct_window(rec, cycle_frames, ply, layout, quality,
                                            depth=None if depths is None else depths[i])
        yield k, cyc, was_empty


def write_ply_frame(ply_dir: Path, k: int, cycle: Cycle) -> None:
    """3D frame ``k``'s points and texture as ``ply_dir/frame_NNNNN.ply`` (the measurement PLY,
    :func:`fringe3d.io.ply_standard.write_measurement_ply`); nothing for a frame with no point."""
    if cycle.points is not None and np.isfinite(cycle.points[..., 0]).any():
        write_measurement_ply(Path(ply_dir) / ply_name(k), cycle.points, cycle.texture)


def store_arrays(cycle: Cycle, st: PointMapStore) -> dict:
    """The keyword arguments of :meth:`PointMapStore.write_frame` for ``cycle`` in ``st``."""
    out: dict = {"points": cycle.points} if st.layout == "xyz" else {"depth": cycle.depth}
    if st.has_quality:
        out["quality"] = cycle.quality
    if st.has_sigma:
        H, W = cycle.quality.shape
        out["sigma_z"] = (cycle.sigma_z if cycle.sigma_z is not None
                          else np.full((H, W), np.nan, np.float32))
    return out


# ----------------------------------------------------------------------------- sequences
_READ_POOL = ThreadPoolExecutor(max_workers=min(8, os.cpu_count() or 1), thread_name_prefix="fringe3d-read")


class CaptureFrames:
    """The frames of a capture folder, read on demand: ``frames[idx]`` reads only those files.

    Stands in for the ``(F, H, W)`` array of :func:`reconstruct_sequence` so a capture of
    thousands of frames never has to fit in memory. ``limit`` keeps only the first frames.
    """

    def __init__(self, folder, limit: int | None = None):
        self._read = read_image
        self.files = list_frame_files(folder)[:limit]
        if not self.files:
            raise ValueError(f"capture folder {folder} holds no frames")
        first = read_image(self.files[0])
        self.shape = (len(self.files),) + first.shape
        self.dtype = first.dtype
        self.ndim = 3

    def __len__(self) -> int:
        return self.shape[0]

    def _one(self, k: int) -> np.ndarray:
        img = self._read(self.files[k])
        if img.shape != self.shape[1:] or img.dtype != self.dtype:
            raise ValueError(f"{self.files[k]} is {img.dtype} {img.shape} but {self.files[0].name} is "
                             f"{self.dtype} {self.shape[1:]}; all frames of a capture must match")
        return img

    def __getitem__(self, idx):
        if np.ndim(idx) == 0:
            return self._one(int(idx))
        ks = [int(k) for k in np.asarray(idx).ravel()]
        if len(ks) < 2:
            return np.stack([self._one(k) for k in ks])
        # PNG/TIFF decoders release the GIL: a cycle's frames decode in parallel
        return np.stack(list(_READ_POOL.map(self._one, ks)))


def ply_name(k: int) -> str:
    return f"frame_{k:05d}.ply"


def store_layout(rec: FrameReconstructor, layout: str = "auto") -> str:
    """The point store layout for ``rec``'s reconstruction: ``"auto"`` is ``"ray_depth"`` where it
    is exact (the fused path), else ``"xyz"``; ``"ray_depth"`` where it is not exact is an error."""
    if layout == "auto":
        return rec.store_layout
    if layout not in LAYOUTS:
        raise ValueError(f"unknown store layout {layout!r}; expected auto, {', '.join(LAYOUTS)}")
    if layout == "ray_depth" and rec.store_layout != "ray_depth":
        raise ValueError(f"the ray_depth store layout needs the fused 3-step + geometric path; this manifest and rig "
                         f"take {rec.path!r}, whose points are stored as xyz (use `store_layout` auto or xyz)")
    return layout


def prepare_sequence(shape: tuple[int, ...], patterns: PatternSet, rig: Rig, out: Path,
                     options: DecodeOptions | None, mode: str, step: int | None, ply: bool,
                     store: bool, rec: FrameReconstructor, layout: str = "auto",
                     store_quality: bool = True, codec: str | None = None,
                     frame_rate: float | None = None) -> tuple[list[int], PointMapStore | None]:
    """Check a sequence of frames of ``shape`` (F, H, W) against the rig, create (or resume) the
    point store and the PLY folder in ``out``; returns the windows' first frames and the store.

    ``rec`` (the sequence's reconstructor) chooses the store ``layout`` (:func:`store_layout`);
    ``store_quality`` adds the per-frame quality and sigma_z arrays; ``codec`` compresses them
    (:data:`fringe3d.io.store.CODECS`, default lz4); ``frame_rate`` (Hz, when known) gives the
    store's ``time`` coordinate: each 3D frame's first captured frame / rate (s)."""
    if not (ply or store):
        raise ValueError("nothing to write: ask for the point store and/or PLY files")
    if len(shape) != 3:
        raise ValueError(f"frames must be an (F, H, W) stack, got shape {tuple(shape)}")
    H, W = shape[1:]
    ch, cw = camera_shape(rig)
    if (ch, cw) != (H, W):
        raise ValueError(f"the capture is {W}x{H} pixels but the calibration's camera is {cw}x"
                         f"{ch}: calibration and capture sizes disagree")
    z_min = (options or DecodeOptions()).z_min
    starts = window_starts(shape[0], len(patterns), mode, step)
    st = None
    lay = store_layout(rec, layout) if store else None  # a layout the reconstruction cannot fill: before writing
    out.mkdir(parents=True, exist_ok=True)
    meta = {"patterns": patterns.name, "mode": mode, "step": step, "z_min": z_min, "rig": rig.to_dict(),
            "window_starts": [starts[0], starts[-1], len(starts)]}
    if lay is not None:
        st = PointMapStore.open(out / STORE_NAME, len(starts), H, W, meta=meta, layout=lay,
                                rays=rec.rays if lay == "ray_depth" else None, quality=store_quality,
                                sigma=store_quality, codec=codec,
                                times=None if frame_rate is None else np.asarray(starts, np.float64) / frame_rate)
    if ply:
        (out / PLY_DIR).mkdir(exist_ok=True)
    return starts, st


#: Cycles per batched launch on the CUDA backend (one cycle at a time on the CPU).
CUDA_BATCH = 32
#: Written frames marked done at once (one write of the store's ``done`` array and attributes; an
#: interrupted run recomputes at most this many frames whose chunks were already written).
MARK_EVERY = 16


def reconstruct_sequence(frames: np.ndarray, patterns: PatternSet, rig: Rig, out,
                         options: DecodeOptions | None = None, mode: str = "cycle", step: int | None = None,
                         ply: bool = False, store: bool = True, progress: bool = True, triangulation: str = "auto",
                         fast: bool = True, layout: str = "auto", store_quality: bool = True,
                         backend: str = "cpu", codec: str | None = None, allow_relative: bool = False,
                         frame_rate: float | None = None) -> dict:
    """Reconstruct every 3D frame of a sequence into ``out`` (resumable).

    Parameters
    ----------
    frames : (F, H, W) array (or a memory map, or :class:`CaptureFrames`), in projection order
    patterns : the manifest (its plans choose the unwrapping; see :func:`with_method`)
    rig : the calibrated rig
    options : :class:`fringe3d.decode.DecodeOptions` (``z_min`` in mm for geometric-constraint
        methods, ``bit_depth``, ``min_modulation``, ...)
    out : output folder: ``points.zarr`` and/or ``ply/frame_00000.ply`` ...
    mode, step : ``"cycle"`` or ``"window"`` (one 3D frame every ``step`` captured frames)
    ply, store : which outputs to write (at least one)
    layout : point store layout, ``"auto"`` (``"ray_depth"`` where exact), ``"xyz"`` or
        ``"ray_depth"`` (:mod:`fringe3d.io.store`)
    store_quality : also store each 3D frame's quality map and sigma_z (mm)
    codec : the store's compression, ``"lz4"`` (default), ``"zstd"`` or ``"none"``
        (:data:`fringe3d.io.store.CODECS`; its cost per 3D frame: ``docs/long-sequences.md``)
    backend : ``"cpu"`` or ``"cuda"`` (:class:`FrameReconstructor`; on the CUDA fused path
        :data:`CUDA_BATCH` cycles go to the device per launch)
    allow_relative : triangulate a wrapped or relative phase anyway (:class:`FrameReconstructor`;
        ``RelativePhaseError`` before anything is written otherwise)
    frame_rate : the camera's frame rate (Hz) when known: the store's ``time`` coordinate (s)

    Returns a summary dict (3D frames, done now / before, seconds, 3D frames per second, path,
    store layout).
    """
    frames = frames if hasattr(frames, "shape") else np.asarray(frames)
    out = Path(out)
    options = options or DecodeOptions()
    rec = FrameReconstructor(patterns, rig, options, triangulation=triangulation, fast=fast, backend=backend,
                             allow_relative=allow_relative)
    starts, st = prepare_sequence(frames.shape, patterns, rig, out, options, mode, step, ply, store, rec=rec,
                                  layout=layout, store_quality=store_quality, codec=codec, frame_rate=frame_rate)

    def done(k):
        return (st is None or st.is_done(k)) and (not ply or (out / PLY_DIR / ply_name(k)).exists())

    todo = [k for k in range(len(starts)) if not done(k)]
    st_layout = st.layout if st is not None else None
    quality = st is not None and st.has_quality
    batch = CUDA_BATCH if backend == "cuda" else 1
    t0 = time.perf_counter()
    empty = 0
    writes: deque = deque()  # store writes run behind the next frame's compute (compression is off the critical path)
    written: list[int] = []  # frames whose chunks are written, to be marked done (every MARK_EVERY frames)
    with progress_bar("reconstructing 3D frames", len(todo), enabled=progress and len(todo) > 1) as advance, \
            ThreadPoolExecutor(max_workers=1, thread_name_prefix="fringe3d-store") as writer, \
            _kernel_threads_beside(st is not None):
        try:
            for b0 in range(0, len(todo), batch):
                for k, cyc, was_empty in reconstructed_windows(rec, frames, starts, todo[b0:b0 + batch], ply,
                                                               st_layout, quality):
                    empty += was_empty
                    if ply:
                        write_ply_frame(out / PLY_DIR, k, cyc)
                    if st is not None:
                        writes.append((k, writer.submit(st.write_frame, k, **store_arrays(cyc, st))))
                        while len(writes) > 2:  # at most two frames in flight: bounded memory
                            written.append(_finish(writes.popleft()))
                        if len(written) >= MARK_EVERY:
                            st.mark_done(written)
                            written.clear()
                    advance()
            while writes:
                written.append(_finish(writes.popleft()))
        finally:  # also when interrupted: the frames whose writes finished are marked, so a rerun skips them
            if st is not None:
                _drain(writes, written)
                st.mark_done(written)
    dt = time.perf_counter() - t0
    return {"out": str(out), "frames_3d": len(starts), "done_now": len(todo), "done_before": len(starts) - len(todo),
            "empty_frames": empty, "seconds": round(dt, 3),
            "frames_3d_per_s": (len(todo) / dt) if todo and dt > 0 else None, "path": rec.path, "mode": mode,
            "backend": backend,
            "store": str(out / STORE_NAME) if store else None, "ply_dir": str(out / PLY_DIR) if ply else None,
            "store_layout": st.layout if st is not None else None}


@contextlib.contextmanager
def _kernel_threads_beside(writer: bool):
    """While a store writer thread runs beside the kernels, the numba kernels of this thread use
    one thread fewer (at least one): every parallel kernel waits for its slowest thread, and a
    thread sharing its core with the writer's compression made each kernel up to twice as slow
    (``benchmarks/bench_sequence.py`` on 2 cores)."""
    n = numba.get_num_threads()
    if writer and n > 1:
        numba.set_num_threads(n - 1)
    try:
        yield
    finally:
        numba.set_num_threads(n)


def _finish(pending: tuple) -> int:
    """The frame index of a ``(k, future)`` store write, once the write has finished (it raises if
    the write did)."""
    k, fut = pending
    fut.result()
    return k


def _drain(writes: deque, written: list[int]) -> None:
    """Wait for the store writes still in flight; append to ``written`` those that succeeded."""
    while writes:
        k, fut = writes.popleft()
        if fut.exception() is None:
            written.append(k)
