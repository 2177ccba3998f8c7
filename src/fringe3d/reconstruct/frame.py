"""The engine: one cycle of frames -> decoded fields -> points (:class:`FrameReconstructor`).

Built once per rig and manifest, it reconstructs one cycle (the manifest's frames, in manifest
order) into a :class:`Cycle`: points, texture, quality bits and predicted sigma. Two paths give
the same numbers as :func:`fringe3d.decode.decode` + :func:`fringe3d.reconstruct.depth.
points_from_decoded`: the decode path itself, and for a single-direction 3-step manifest
unwrapped by the geometric constraint the fused :class:`~fringe3d.reconstruct.triangulate.
FastThreeStep` kernel with the decode path's quality rules (:mod:`fringe3d.reconstruct.
fast_quality`). Sequencing many cycles into files is :mod:`fringe3d.reconstruct.sequence`.
"""
from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Callable, Iterator, NamedTuple

import numpy as np

from fringe3d.decode.context import phase_groups
from fringe3d.decode.decoder import decode
from fringe3d.decode.edges import INVALID, QualityTests, edge_margin, oblique_factor, pixel_extent
from fringe3d.decode.method_plans import with_method as plans_with_method
from fringe3d.decode.options import DecodeOptions
from fringe3d.decode.plan_checks import check_plans
from fringe3d.decode.texture import as_fraction, fringe_texture
from fringe3d.gpu.runtime import check_backend
from fringe3d.io.store import LAYOUTS
from fringe3d.optics.rig import Rig
from fringe3d.optics.rig_geometry import RigGeometry
from fringe3d.patterns.conventions import w_range, w_to_phase
from fringe3d.patterns.manifest import PatternSet
from fringe3d.patterns.method_registry import method_facts
from fringe3d.phase.quality import default_min_modulation, full_scale
from fringe3d.reconstruct.depth import EmptyMaskError, points_from_decoded
from fringe3d.reconstruct.fast_quality import fast_quality
from fringe3d.reconstruct.triangulate import FastThreeStep, ThreeStepFields, Triangulator
from fringe3d.reconstruct.uncertainty import point_sigma
from fringe3d.reconstruct.windows import window_index
from fringe3d.unwrap.geometric import cached_minimum_phase, check_wrap_around
from fringe3d.utils.freed_memory import keep_freed_memory
from fringe3d.utils.warning_types import ReconstructionWarning

#: GRADIENT's floor on the jump of ``w`` (px) on the fused path: the quality map's default
#: (:class:`~fringe3d.decode.edges.QualityTests`), which :func:`fast_quality` keeps.
GRADIENT_FLOOR = QualityTests.gradient_floor


# ----------------------------------------------------------------------------- plans
def reconstruction_plans(ps: PatternSet, method: str | None) -> PatternSet:
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


class Cycle(NamedTuple):
    """One reconstructed cycle: ``points`` (H, W, 3) float32 mm (NaN invalid; None when not
    asked for), ``texture`` (H, W) float32 in [0, 1] (None when not asked for), ``quality`` (H, W) uint8 bits
    (:mod:`fringe3d.decode.edges`; 0 = kept), ``sigma_xyz`` (H, W, 3) float32 mm predicted
    standard deviations (or None), on the fused path ``depth`` (H, W) float32: the ray
    parameter ``s`` of every point (``points = ray_points(O, D, depth)``; None elsewhere),
    ``sigma_z`` (H, W) float32 mm, ``sigma_xyz``'s z (or None), ``sigma_later``: where
    ``sigma_z`` was left for later (uncertainty ``"z later"``), the function computing it
    (:func:`with_sigma`), else None."""

    points: np.ndarray | None
    texture: np.ndarray | None
    quality: np.ndarray
    sigma_xyz: np.ndarray | None
    depth: np.ndarray | None = None
    sigma_z: np.ndarray | None = None
    sigma_later: Callable[[], np.ndarray] | None = None


class LaterCycle(NamedTuple):
    """A cycle of the fused path whose kernel pass is done and the rest left for later
    (:meth:`FrameReconstructor.fused_later`): ``depth`` (H, W) float32, the kernel's ray
    parameters (not yet masked by the quality tests), and ``later``, the function making the
    finished :class:`Cycle` (:func:`with_sigma`)."""

    depth: np.ndarray
    later: Callable[[], Cycle]


def with_sigma(cycle: Cycle | LaterCycle) -> Cycle:
    """``cycle`` finished: its quality map, masked depth and ``sigma_z`` computed where they were
    left for later (a :class:`LaterCycle`), or its ``sigma_z`` alone (``sigma_later``); the same
    arrays as when computed at once."""
    if isinstance(cycle, LaterCycle):
        cycle = cycle.later()
    if cycle.sigma_later is None:
        return cycle
    return cycle._replace(sigma_z=cycle.sigma_later(), sigma_later=None)


class FrameReconstructor:
    """Turns one cycle of frames (manifest order) into an ``(H, W, 3)`` float32 point map.

    Built once per rig and manifest: the minimum phase map and ray coefficients are computed
    once and kept in :attr:`geometry`, the rig's
    :class:`~fringe3d.optics.rig_geometry.RigGeometry` that this engine owns (or shares, when a
    ``geometry`` of the same rig is passed: engines for one rig then compute each map once);
    nothing else holds the rig. ``fast=True`` takes the fused :class:`FastThreeStep` kernel when the manifest is one
    3-step direction unwrapped by ``"geometric"`` and the projector has no distortion (it masks by
    modulation, then the edge and mixed-pixel tests of :mod:`fringe3d.reconstruct.fast_quality`;
    saturation is not checked on that path).

    ``backend="cuda"`` runs the per-pixel kernels on a CUDA device (:mod:`fringe3d.gpu`): on the
    fused path the fused kernel with the quality tests, the texture and ``sigma_z``
    (:meth:`device_cycles`; ``sigma_xyz`` stays on the CPU), on the decode path the default
    three-frequency decode with its assessment (quality bits, phase sigma, texture:
    :mod:`fringe3d.decode.device_temporal`), other methods on the CPU (``DecodeOptions.backend``;
    triangulation and ``sigma_xyz`` stay on the CPU).
    The results equal the CPU backend's: quality bits exactly, float maps to float rounding.

    The plans are checked first (:func:`fringe3d.decode.plan_checks.check_plans`): a geometric
    method without ``options.z_min`` raises ``MissingGeometryError``, a wrapped or relative
    phase (method ``none``, ``spatial``) ``RelativePhaseError`` unless ``allow_relative``, which
    triangulates it with a :class:`~fringe3d.utils.warning_types.ReconstructionWarning` and
    lists its directions in :attr:`relative`.
    """

    def __init__(self, patterns: PatternSet, rig: Rig, options: DecodeOptions | None = None,
                 triangulation: str = "auto", fast: bool = True, backend: str = "cpu",
                 allow_relative: bool = False, geometry: RigGeometry | None = None):
        keep_freed_memory()
        self.patterns = patterns
        self.rig = rig
        self.geometry = RigGeometry.of(rig, geometry)
        self.backend = check_backend(backend)
        self.options = dataclasses.replace(options or DecodeOptions(), backend=self.backend)
        self.relative = check_plans(patterns, rig, self.options.z_min, allow_relative=allow_relative,
                                    geometry=self.geometry)
        if self.relative:
            warnings.warn(f"triangulating the wrapped or relative phase of direction(s) {list(self.relative)} "
                          "(allow_relative): the 3D is off by an unknown number of fringe periods in depth",
                          ReconstructionWarning, stacklevel=2)
        self.allow_relative = allow_relative
        self.allow_fused = fast
        self.z_min = self.options.z_min
        self.triangulation = triangulation
        self._range_checked = False
        self.fused = fused_path(patterns, self.geometry, self.options, self.backend) if fast else None
        self.fast = self.fused.kernel if self.fused is not None else None

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

    def __call__(self, frames: np.ndarray) -> np.ndarray | None:
        """Points ``(H, W, 3)`` float32 mm of one cycle (:meth:`reconstruct` without sigma)."""
        return self.reconstruct(frames, uncertainty=False).points

    def on_device(self, uncertainty: bool | str) -> bool:
        """Whether :meth:`device_cycles` makes the outputs: the CUDA fused path, without ``sigma_xyz``
        (``uncertainty`` False or ``"z"``)."""
        return self.fast is not None and self.backend == "cuda" and uncertainty is not True

    def device_cycles(self, cycles: list[np.ndarray], uncertainty: bool | str, points: bool = True,
                      texture: bool = True) -> list[Cycle | None]:
        """Several cycles (each (n, H, W), manifest order) on the CUDA fused path in one batched
        launch, every output made on the device (:func:`fringe3d.gpu.fused_outputs.three_step_outputs`):
        the ray parameters masked by the quality tests, the quality map, ``sigma_z`` (``uncertainty``
        ``"z"``) and the texture (``texture``); the points (``points``) are ``ray_points`` of the
        depth, as on the CPU. Each :class:`Cycle` equals :meth:`reconstruct`'s on the CPU backend
        (quality bits exactly, float maps to float rounding); None for a cycle whose phase mask is
        empty. Only where :meth:`on_device`."""
        from fringe3d.gpu import fused_outputs as fo

        assert self.fused is not None and self.on_device(uncertainty)
        fused, fast = self.fused, self.fused.kernel
        self._set_min_modulation(cycles[0])
        if not self._range_checked:  # once: the depth-range warning, from the points before the edge tests
            self._check_range(fast.depth(cycles[0], index=fused.index))
        out = fo.three_step_outputs(np.stack(cycles), fused.index, self._device_inputs(bool(uncertainty)),
                                    fast.min_mod2, self._quality_settings(cycles[0]), texture)
        res: list[Cycle | None] = []
        for c in range(len(cycles)):
            q = out.quality[c]
            if not (q != INVALID).any():  # no valid pixel: the CPU path's EmptyMaskError
                res.append(None)
                continue
            depth = out.depth[c]
            tex = None if out.texture is None else out.texture[c]
            res.append(Cycle(fast.ray_points(depth) if points else None, tex, q, None, depth,
                             None if out.sigma_z is None else out.sigma_z[c]))
        return res

    def _device_inputs(self, sigma: bool):
        """The fused path's device inputs (:class:`fringe3d.gpu.fused_outputs.DeviceInputs`), uploaded
        once; with the ``sigma_z`` terms when ``sigma``."""
        from fringe3d.gpu import fused_outputs as fo

        assert self.fused is not None
        fast = self.fused.kernel
        if getattr(self, "_device", None) is None:
            geometry, constants = fast.device_geometry()
            qo, po, qd, pd = fast.tri._ray_rows()
            rows = fo.SigmaRows(po * qd - qo * pd, qd, pd, float(np.float32(fast.mp.period / (2 * math.pi))),
                                len(self.fused.index))  # the operations of RayGeometry.sigma_z_from_phase_noise
            self._device = fo.device_inputs(geometry, rows)
        return self._device if sigma else self._device._replace(sigma=None, sigma_maps=None)

    def _quality_settings(self, frames: np.ndarray):
        """The fused path's quality rules as numbers (:func:`fringe3d.reconstruct.fast_quality.fast_quality`'s
        arguments to :func:`fringe3d.decode._fused_quality.fused_quality_map`)."""
        from fringe3d.gpu.fused_outputs import QualitySettings

        assert self.fused is not None
        opt = self.options
        lo, hi = self.fused.extent
        margin = edge_margin(opt.edge_margin) * oblique_factor(self.fused.kernel.mp.angle)  # as decode.assess
        return QualitySettings(bool(opt.edge_mask), lo + margin, hi - margin, float(opt.gradient_ratio),
                               GRADIENT_FLOOR, float(opt.modulation_ratio), int(opt.rim),
                               full_scale(frames, opt.bit_depth))

    def _set_min_modulation(self, frames: np.ndarray) -> None:
        """The fused path's modulation threshold for ``frames`` (default: from their bit depth)."""
        assert self.fused is not None
        mm = self.fused.min_modulation
        self.fused.kernel.set_min_modulation(default_min_modulation(frames, self.options.bit_depth) if mm is None
                                             else mm)

    def reconstruct(self, frames: np.ndarray, uncertainty: bool | str = True, points: bool = True,
                    texture: bool = True, depth: np.ndarray | None = None) -> Cycle:
        """One cycle (manifest order) -> :class:`Cycle`: points, texture, quality map (OR of the
        directions' bits, :mod:`fringe3d.decode.edges`) and, with ``uncertainty``, ``sigma_xyz``
        and ``sigma_z`` (:mod:`fringe3d.reconstruct.uncertainty`; ``"z"``: on the fused path
        ``sigma_z`` alone; ``"z later"``: there its function, ``Cycle.sigma_later``, except on the
        device, which makes ``sigma_z`` at once). Both paths mask edge and mixed pixels unless
        ``options.edge_mask`` is False. ``points=False`` leaves ``points`` None on the fused path (its ``depth`` holds
        them), ``texture=False`` leaves ``texture`` None there. ``depth``: the fused kernel's ray
        parameters for these frames, already computed. On the CUDA fused path without ``sigma_xyz``
        or ``depth`` every output is made on the device (:meth:`device_cycles`)."""
        if self.on_device(uncertainty) and depth is None:
            cycle = self.device_cycles([frames], "z" if uncertainty == "z later" else uncertainty, points,
                                       texture)[0]
            if cycle is None:
                raise EmptyMaskError("the decoded phase mask is empty: no pixel has enough fringe modulation (check "
                                     "exposure, modulation threshold and that the scene is lit by the projector)")
            return cycle
        if self.fast is not None:
            return self._reconstruct_fused(frames, uncertainty, points, texture, depth)
        dec = decode(frames, self.patterns, rig=self.rig, options=self.options, geometry=self.geometry)
        pts = points_from_decoded(dec, self.rig, method=self.triangulation, geometry=self.geometry)
        tex = np.asarray(dec.texture, np.float32)  # a fraction of full scale already (fringe3d.decode.texture)
        quality = np.zeros(pts.shape[:2], np.uint8)
        for q in dec.quality.values():
            quality |= q
        quality[~np.isfinite(pts[..., 0]) & (quality == 0)] |= INVALID  # e.g. behind the camera
        sigma = (point_sigma(dec, self.rig, method=self.triangulation, geometry=self.geometry) if uncertainty
                 else None)
        return Cycle(pts, tex, quality, sigma, sigma_z=None if sigma is None else np.ascontiguousarray(sigma[..., 2]))

    def _fused_fields(self, frames: np.ndarray, uncertainty: bool | str, texture: bool,
                      depth: np.ndarray | None) -> ThreeStepFields:
        """The fused kernel's pass of :meth:`reconstruct` (``w``, ``A`` and ``B`` where the quality
        tests, sigma_z or the texture need them), the depth-range warning checked once."""
        fused = self.fused
        assert fused is not None
        fast = fused.kernel
        if depth is not None:  # computed elsewhere: w, A, B are recomputed
            fields = ThreeStepFields(depth)
        else:
            self._set_min_modulation(frames)
            if self.backend == "cpu" and (self.options.edge_mask or uncertainty or texture):
                fields = fast.depth_fields(frames, fused.index)
            else:
                fields = ThreeStepFields(fast.depth(frames, index=fused.index))
        if not self._range_checked:  # once: the depth-range warning the decode path gives
            self._check_range(fields.depth)
        return fields

    def fused_later(self, frames: np.ndarray, uncertainty: bool | str) -> LaterCycle:
        """The fused path's kernel pass on ``frames`` now and the rest of :meth:`reconstruct`
        (``points=False, texture=False``) left to the returned :class:`LaterCycle`: the quality
        map, the masking of the depth and ``sigma_z`` (:func:`with_sigma` makes the cycle
        :meth:`reconstruct` gives, the same arrays), on whichever thread calls it.
        :class:`~fringe3d.reconstruct.depth.EmptyMaskError` now when no pixel is valid."""
        fused = self.fused
        assert fused is not None and self.fast is not None
        fields = self._fused_fields(frames, uncertainty, False, None)
        if not np.isfinite(fields.depth).any():
            raise EmptyMaskError("the decoded phase mask is empty: no pixel has enough fringe modulation (check "
                                 "exposure, modulation threshold and that the scene is lit by the projector)")

        def finish() -> Cycle:
            fq = fast_quality(fused.kernel, frames, fused.index, fused.shifts, fields, fused.extent, self.options,
                              uncertainty)
            return Cycle(None, None, fq.quality, fq.sigma_xyz, fields.depth, fq.sigma_z, fq.sigma_later)

        return LaterCycle(fields.depth, finish)

    def _reconstruct_fused(self, frames: np.ndarray, uncertainty: bool | str, points: bool, texture: bool,
                           depth: np.ndarray | None) -> Cycle:
        """:meth:`reconstruct` on the fused path: one kernel pass gives the ray parameters and,
        where the quality tests, sigma_z or the texture need them, ``w``, ``A`` and ``B``."""
        fused = self.fused
        assert fused is not None
        fast = fused.kernel
        fields = self._fused_fields(frames, uncertainty, texture, depth)
        depth = fields.depth
        fq = fast_quality(fast, frames, fused.index, fused.shifts, fields, fused.extent,
                          self.options, uncertainty)
        tex = None
        if texture:  # A + B as decode's; the kernel or the quality tests already have them
            tex = (as_fraction(np.add(fq.average, fq.modulation, dtype=np.float32), frames, self.options.bit_depth)
                   if fq.average is not None and fq.modulation is not None else
                   fringe_texture(frames, fused.shifts, fused.index, self.options.bit_depth))
        pts = fast.ray_points(depth) if points else None
        return Cycle(pts, tex, fq.quality, fq.sigma_xyz, depth, fq.sigma_z, fq.sigma_later)

    def _check_range(self, depth: np.ndarray) -> None:
        """The depth-range warning of the decode path (:func:`fringe3d.unwrap.geometric.
        check_wrap_around`) from the points of ``depth`` before the edge tests mask any (an
        empty mask is left to :func:`fast_quality`): their projector fringe coordinate by the
        linear projector model (the fused path's projector has no distortion) along the rays,
        :meth:`~fringe3d.optics.rays.RayGeometry.fringe_coordinate_at` (one pass; the points
        themselves and their projection cost 0.06 s at 1280 x 1024, on the first frame's path)."""
        assert self.fast is not None
        mp = self.fast.mp
        valid = np.isfinite(depth)
        if not valid.any():
            return
        w = self.fast.tri.fringe_coordinate_at(depth)
        check_wrap_around(np.where(valid, w_to_phase(w, mp.period, scale_first=True), np.nan), mp, valid)
        self._range_checked = True


def reconstruct_window(rec: FrameReconstructor, frames: np.ndarray, ply: bool, layout: str | None,
                       quality: bool, depth: np.ndarray | None = None,
                       later: bool | str = False) -> tuple[Cycle | LaterCycle, bool]:
    """One window (manifest order) for a sequence's outputs: ``(cycle, empty)``.

    ``ply`` asks for points and texture, ``layout`` (the store's, or None) for the points
    (``"xyz"``) or only the ray parameters (``"ray_depth"``), ``quality`` for the quality map
    and ``sigma_z``, ``depth`` for the fused kernel's ray parameters already computed,
    ``later`` True to leave the fused path's ``sigma_z`` to ``Cycle.sigma_later`` or ``"all"``
    to leave, on the CPU without points, everything after the fused kernel (quality map,
    masking, sigma_z) to a :class:`LaterCycle` (:meth:`FrameReconstructor.fused_later`;
    :func:`with_sigma`: the store writers' threads compute it, beside the next windows'
    kernels). A window
    whose phase mask is empty gives an all-NaN, all-INVALID cycle and ``empty = True``.
    """
    want_points = ply or layout == "xyz"
    try:
        if later == "all" and depth is None and not want_points and rec.fast is not None and rec.backend == "cpu":
            return rec.fused_later(frames, "z" if quality else False), False
        return rec.reconstruct(frames, uncertainty=("z later" if later else "z") if quality else False,
                               points=want_points, texture=ply, depth=depth), False
    except EmptyMaskError:
        return empty_cycle(rec, frames.shape[1:], want_points), True


def empty_cycle(rec: FrameReconstructor, shape: tuple[int, int], points: bool) -> Cycle:
    """The cycle of a window whose phase mask is empty: NaN points (when ``points``) and depth
    (on the fused path), every pixel INVALID."""
    H, W = shape
    return Cycle(np.full((H, W, 3), np.nan, np.float32) if points else None, None,
                 np.full((H, W), INVALID, np.uint8), None, np.full((H, W), np.nan, np.float32) if rec.fast is not None
                 else None)


def window_frames(frames, starts, ks: list[int], n: int) -> list[np.ndarray]:
    """The contiguous ``(n, H, W)`` frames (manifest order, :func:`~fringe3d.reconstruct.windows.
    window_index`) of each 3D frame ``k`` of ``ks``, read from ``frames`` (F, H, W) at ``starts[k]``;
    from a frame source with ``read(start, stop)`` (:class:`~fringe3d.io.frame_sources.FrameRange`:
    a camera file), a window already in manifest order is read as its span, a fresh array (its
    index would copy the span once more: 0.9 instead of 0.6 ms a 1280 x 1024 cycle)."""
    read = getattr(frames, "read", None) if not isinstance(frames, np.ndarray) else None
    out = []
    for k in ks:
        index = window_index(starts[k], n)
        if read is not None and bool(np.all(np.diff(index) == 1)):
            out.append(np.ascontiguousarray(read(int(index[0]), int(index[-1]) + 1)))
        else:
            out.append(np.ascontiguousarray(frames[index]))
    return out


def reconstructed_cycles(rec: FrameReconstructor, ks: list[int], cycles: list[np.ndarray], ply: bool,
                         layout: str | None, quality: bool,
                         later: bool | str = False) -> Iterator[tuple[int, Cycle | LaterCycle, bool]]:
    """``(k, cycle, empty)`` of each 3D frame ``k`` of ``ks`` from its frames already read
    (``cycles``, :func:`window_frames`; :func:`reconstruct_window`); on the CUDA fused path all of
    them come finished from one batched launch (:meth:`FrameReconstructor.device_cycles`);
    elsewhere ``later`` leaves sigma_z or all but the kernel's pass for later
    (:func:`reconstruct_window`)."""
    uncertainty = "z" if quality else False
    if cycles and rec.on_device(uncertainty):
        want_points = ply or layout == "xyz"
        for k, dev in zip(ks, rec.device_cycles(cycles, uncertainty, want_points, ply)):
            yield (k, dev, False) if dev is not None else (k, empty_cycle(rec, cycles[0].shape[1:], want_points), True)
        return
    for k, cycle_frames in zip(ks, cycles):
        cyc, was_empty = reconstruct_window(rec, cycle_frames, ply, layout, quality, later=later)
        yield k, cyc, was_empty


def reconstructed_windows(rec: FrameReconstructor, frames, starts, ks: list[int], ply: bool, layout: str | None,
                          quality: bool) -> Iterator[tuple[int, Cycle | LaterCycle, bool]]:
    """``(k, cycle, empty)`` of each 3D frame ``k`` of ``ks`` (:func:`reconstructed_cycles`), its
    window read from ``frames`` (F, H, W) at ``starts[k]`` (:func:`window_frames`). The
    per-frame loop of the threaded and the Dask paths (the serial one reads ahead)."""
    yield from reconstructed_cycles(rec, ks, window_frames(frames, starts, ks, len(rec.patterns)), ply, layout,
                                    quality)


@dataclasses.dataclass(frozen=True)
class FusedPath:
    """What the fused 3-step path needs besides its kernel: the phase group's frame ``index``
    (3,) and ``shifts`` (rad), the valid fringe-coordinate ``extent`` (px, widened by half a
    pixel's extent as the decode path's, :mod:`fringe3d.decode.assess`) and the modulation
    threshold ``min_modulation`` (counts; None: from the frames' bit depth)."""

    kernel: FastThreeStep
    index: np.ndarray
    shifts: tuple
    extent: tuple[float, float]
    min_modulation: float | None


def fused_path(patterns: PatternSet, geometry: RigGeometry, options: DecodeOptions, backend: str) -> FusedPath | None:
    """The fused path for ``patterns`` on ``geometry.rig`` (its :class:`RigGeometry`), or None
    where it does not apply: it needs one 3-step direction unwrapped by ``"geometric"`` with
    ``options.z_min``, a pinhole camera and a projector without distortion."""
    plans, rig = patterns.plans, geometry.rig
    if len(plans) != 1 or plans[0].method != "geometric" or options.z_min is None or rig.telecentric:
        return None
    if rig.projector.dist.any():
        return None
    groups = phase_groups(patterns, plans[0].direction)
    if len(groups) != 1 or len(groups[0].indices) != 3 or len(patterns) != 3:
        return None
    g = groups[0]
    mp = cached_minimum_phase(geometry, options.z_min, g.period, g.angle)
    wr = plans[0].options.get("w_range")
    lo, hi = (float(wr[0]), float(wr[1])) if wr is not None else w_range(g.angle, patterns.width, patterns.height)
    kernel = FastThreeStep(Triangulator(rig, g.angle, warn_distortion=False, geometry=geometry), mp, g.shifts,
                           min_modulation=0.0, backend=backend)
    return FusedPath(kernel, np.asarray(g.indices, np.int64), g.shifts, pixel_extent(lo, hi, g.angle),
                     options.min_modulation)


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
