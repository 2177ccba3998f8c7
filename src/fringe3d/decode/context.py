"""The decoding context of one fringe direction: phase groups, their wrapped phase and masks.

:class:`DecodeContext` is what every method of :data:`fringe3d.decode.METHODS` receives. It
groups the manifest's frames of one direction into :class:`PhaseGroup` s, computes each
group's wrapped phase once (least squares, Eq. 2.4; modified FTP, Eq. 4.5-4.7; FTP,
Eq. 4.1-4.4, with the lobe chosen by :func:`ftp_lobe_angle`) and its validity mask.
"""
from __future__ import annotations

import functools
import warnings
import weakref
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from fringe3d.decode import compensation
from fringe3d.decode._finish_kernels import float32_threshold, valid_phase
from fringe3d.decode.options import DecodeOptions
from fringe3d.optics.rays import camera_shape, pixel_rays
from fringe3d.optics.rig import Rig
from fringe3d.optics.rig_geometry import RigGeometry
from fringe3d.patterns.conventions import fringe_coordinate, w_range
from fringe3d.patterns.manifest import DirectionPlan, PatternSet
from fringe3d.phase import clipping, ftp, noise, quality
from fringe3d.phase.psp import PhaseResult, wrapped_phase, wrapped_phase_and_mask
from fringe3d.utils.camera_size import check_camera_size
from fringe3d.utils.warning_types import CalibrationWarning


class MaskPass(NamedTuple):
    """What the PSP pass that made a group's mask (:meth:`DecodeContext.valid_group_phase`) also
    made, for the assessment of that mask: ``not_mask`` (H, W) uint8 ``~mask`` (0/1) and
    ``laplacian``, the ``(sum, count)`` of :func:`fringe3d.phase.noise.interior_laplacian` of
    ``(average, mask)``; valid only for these very ``mask`` and ``average`` objects."""

    mask: np.ndarray
    average: np.ndarray
    not_mask: np.ndarray
    laplacian: tuple[float, int]


@dataclass(frozen=True)
class PhaseGroup:
    """The frames of one phase group of a direction: label, period (px), fringe angle (rad),
    frame indices and shifts (rad) in step order, and the frame kind."""

    name: str
    period: float
    angle: float
    indices: tuple[int, ...]
    shifts: tuple[float, ...]
    kind: str


@dataclass
class DecodeContext:
    """Everything an unwrapper may need for one fringe direction.

    Attributes: ``frames`` (F, H, W) camera frames of one cycle (any real dtype),
    ``patterns`` the :class:`PatternSet`, ``direction``, ``plan`` (:class:`DirectionPlan`),
    ``rig`` (:class:`fringe3d.optics.Rig` or None), ``options`` (:class:`DecodeOptions`),
    ``min_modulation`` (frames' units, resolved), ``geometry`` the rig's precomputed
    :class:`~fringe3d.optics.rig_geometry.RigGeometry` (given by the decoder's caller, else built
    here from ``rig``; it must belong to ``rig``). ``z_min`` and ``bit_depth`` read the
    options. Wrapped phases are computed once per group and cached (``cache``, also for
    methods' own per-direction tables).
    """

    frames: np.ndarray
    patterns: PatternSet
    direction: str
    plan: DirectionPlan
    rig: Rig | None = None
    options: DecodeOptions = field(default_factory=DecodeOptions)
    min_modulation: float = 0.0
    cache: dict[Any, Any] = field(default_factory=dict, repr=False)
    geometry: RigGeometry | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.rig is not None:
            self.geometry = RigGeometry.of(self.rig, self.geometry)
        elif self.geometry is not None:
            self.rig = self.geometry.rig

    @property
    def z_min(self) -> float | None:
        """The decoder's ``z_min`` (mm) or None (see :meth:`geometry` for the plan's)."""
        return self.options.z_min

    @property
    def bit_depth(self) -> int | None:
        """Sensor bit depth, None for the frames' dtype default."""
        return self.options.bit_depth

    def method_option(self, name: str, default: Any = None) -> Any:
        """A method option: the decoder's (:class:`DecodeOptions`) if set, else the plan's
        ``options[name]``, else ``default``."""
        value = getattr(self.options, name)
        return self.plan.options.get(name, default) if value is None else value

    # -- groups ------------------------------------------------------------------------
    def phase_groups(self) -> list[PhaseGroup]:
        """Phase groups of this direction in manifest order (see :func:`phase_groups`), read from
        the manifest once per context (``cache[("phase_groups",)]``)."""
        groups = self.cache.get(("phase_groups",))
        if groups is None:
            groups = self.cache[("phase_groups",)] = phase_groups(self.patterns, self.direction)
        return list(groups)

    def group_for_period(self, period: float) -> PhaseGroup:
        """The phase group of this direction with the given period (``ValueError`` if none)."""
        groups = self.phase_groups()
        for g in groups:
            if abs(g.period - float(period)) <= 1e-9 * max(1.0, abs(period)):
                return g
        raise ValueError(f"direction {self.direction!r}: plan names period {period:g} px but the manifest's "
                         f"phase groups have periods {[g.period for g in groups]}")

    def groups_for_plan(self) -> list[PhaseGroup]:
        """Groups matching ``plan.periods`` in that order (narrowest first)."""
        if not self.plan.periods:
            return self.phase_groups()
        return [self.group_for_period(p) for p in self.plan.periods]

    # -- phase and quality ---------------------------------------------------------------
    def group_phase(self, group: PhaseGroup) -> PhaseResult:
        """Wrapped phase of a group, cached: :class:`fringe3d.phase.psp.PhaseResult`.

        3 or more steps: least-squares phase shifting (Eq. 2.4). 2 steps shifted by pi:
        modified FTP (Eq. 4.5-4.7). 1 step: FTP (Eq. 4.1-4.4). Options ``ftp_window`` and
        ``ftp_radius`` (:class:`DecodeOptions`) are passed to FTP; the lobe sign follows :func:`ftp_lobe_angle`.
        """
        if group.name not in self.cache:
            self.cache[group.name] = group_phase_and_saturation(self, group)
        return self.cache[group.name][0]

    def group_saturated(self, group: PhaseGroup) -> np.ndarray:
        """(H, W) bool: the group's phase is broken by clipping. A group of 3 or more steps:
        where the clipped samples bias the phase beyond its noise (:func:`clipping_broken`);
        an FTP group: where a frame is at the saturation level."""
        self.group_phase(group)
        clipped = self.cache[group.name][1]
        return clipping_broken(self, group) if len(group.indices) >= 3 and clipped.any() else clipped

    def group_mask(self, group: PhaseGroup) -> np.ndarray:
        """(H, W) bool validity of one group: modulation >= min_modulation and not saturated."""
        pr = self.group_phase(group)
        return (pr.modulation >= self.min_modulation) & ~self.group_saturated(group)

    def valid_group_phase(self, group: PhaseGroup) -> tuple[np.ndarray, np.ndarray]:
        """``(mask, phase)``: :meth:`group_mask` and a finite phase, and the group's wrapped phase
        with NaN outside that mask, (H, W) bool and float32, new arrays: from the pass of the
        group's phase when this is its first use and no pixel is clipped (the saturation map is
        then :meth:`group_saturated`), else one pass of its own
        (:func:`fringe3d.decode._finish_kernels.valid_phase`)."""
        if group.name not in self.cache and len(group.indices) >= 3 and \
                self.options.compensate in (None, "disagreement"):  # as group_phase_and_saturation
            level = quality.saturation_level(self.frames, self.bit_depth)
            pr, sat, valid = wrapped_phase_and_mask(self.frames, group.shifts, group.indices, level,
                                                    float32_threshold(self.min_modulation))
            self.cache[group.name] = (pr, sat)
            if not sat.any():
                # for the assessment of this mask (identity-checked): its Laplacian noise sums over
                # the group's average and ~mask, the INVALID bits (edges.order_bits, no order)
                self.cache[("mask_pass",)] = MaskPass(valid.mask, pr.average, valid.invalid, valid.laplacian)
                return valid.mask, valid.phase
        pr = self.group_phase(group)
        return valid_phase(pr.phase, pr.modulation, self.min_modulation, self.group_saturated(group))

    def w_range(self) -> tuple[float, float]:
        """(w_min, w_max) projector fringe coordinates: the plan's ``options["w_range"]`` if
        given, else the extent of ``w`` over the projector for the plan's angle."""
        wr = self.plan.options.get("w_range")
        if wr is not None:
            return float(wr[0]), float(wr[1])
        return w_range(self.plan.angle, self.patterns.width, self.patterns.height)


#: :func:`phase_groups` of the pattern sets alive, by ``id``: ``(weak reference, {direction:
#: groups})`` (a frozen set's frames do not change; the entry goes with its set).
_GROUPS: dict[int, tuple[weakref.ref, dict[str, tuple[PhaseGroup, ...]]]] = {}


def phase_groups(ps: PatternSet, direction: str) -> list[PhaseGroup]:
    """Phase groups of ``direction``, frames sorted by step, checked for completeness (read
    from the manifest once per set and direction: the decoder asks per cycle).

    Raises ``ValueError`` when a group mixes periods or angles, repeats a step, or has fewer
    frames than its ``steps`` declares.
    """
    key = id(ps)
    entry = _GROUPS.get(key)
    if entry is None or entry[0]() is not ps:
        entry = (weakref.ref(ps, functools.partial(_forget_groups, key)), {})
        _GROUPS[key] = entry
    groups = entry[1].get(direction)
    if groups is None:
        groups = entry[1][direction] = tuple(_read_phase_groups(ps, direction))
    return list(groups)


def _forget_groups(key: int, _ref: weakref.ref) -> None:
    """Drop the :func:`phase_groups` entry of a pattern set that is gone."""
    _GROUPS.pop(key, None)


def _read_phase_groups(ps: PatternSet, direction: str) -> list[PhaseGroup]:
    """:func:`phase_groups` read from the manifest."""
    out = []
    for name in ps.groups(direction=direction, role="phase"):
        idx = [i for i in ps.indices(group=name) if ps.frames[i].role == "phase"]
        specs = [ps.frames[i] for i in idx]
        periods = {s.period for s in specs}
        angles = {s.angle for s in specs}
        if len(periods) != 1 or len(angles) != 1:
            raise ValueError(f"phase group {name!r} mixes periods {sorted(periods)} or angles {sorted(angles)}; "
                             "expected one period and angle per group")
        steps = specs[0].steps or len(specs)
        got = sorted(s.step for s in specs)
        if len(specs) != steps or got != list(range(steps)):
            missing = sorted(set(range(steps)) - set(got))
            raise ValueError(f"phase group {name!r} declares {steps} steps but the manifest holds steps {got}"
                             + (f" (missing {missing})" if missing else "") + "; expected steps 0.."
                             f"{steps - 1} once each")
        order = sorted(range(len(idx)), key=lambda q: specs[q].step)
        out.append(PhaseGroup(name=name, period=float(specs[0].period), angle=float(specs[0].angle),
                              indices=tuple(idx[q] for q in order), shifts=tuple(specs[q].shift for q in order),
                              kind=specs[0].kind))
    return out


def group_phase_and_saturation(ctx: DecodeContext, group: PhaseGroup) -> tuple[PhaseResult, np.ndarray]:
    """Wrapped phase of one group (see :meth:`DecodeContext.group_phase`) and its (H, W) bool
    saturation map (a frame of the group at the sensor's saturation level; what that breaks is
    :meth:`DecodeContext.group_saturated`'s question)."""
    level = quality.saturation_level(ctx.frames, ctx.bit_depth)
    n = len(group.indices)
    if n >= 3:
        pr, sat = wrapped_phase(ctx.frames, shifts=group.shifts, index=group.indices, saturation_level=level,
                                return_saturated=True)
        if ctx.options.compensate not in (None, "disagreement"):  # that one between two passes
            pr, done = compensation.compensate_group(ctx, group, pr)
            ctx.cache.setdefault("radiometry", {}).setdefault("compensation", []).append(done)
        return pr, sat
    sel = ctx.frames[list(group.indices)]
    saturated: np.ndarray = (np.asarray((sel >= level).any(axis=0)) if np.isfinite(level)
                             else np.zeros(sel.shape[1:], bool))
    kw: dict[str, Any] = {}
    if ctx.options.ftp_window is not None:
        kw["window"] = ctx.options.ftp_window
    if ctx.options.ftp_radius is not None:
        kw["radius"] = ctx.options.ftp_radius
    lobe = ftp_lobe_angle(ctx, group)
    if n == 2:
        d = (group.shifts[1] - group.shifts[0]) % (2 * np.pi)
        if abs(d - np.pi) > 1e-6:
            raise ValueError(f"phase group {group.name!r} has 2 frames shifted by {d:.4f} rad; a 2-frame group must "
                             "be a pi-shifted pair (modified FTP)")
        i1, i2 = sel[0].astype(np.float64), sel[1].astype(np.float64)
        phase, mod = ftp.modified_ftp_phase(i1, i2, angle=lobe, **kw)
        average = 0.5 * (i1 + i2)
    else:
        r = ftp.ftp_analysis(sel[0].astype(np.float64), angle=lobe, **kw)
        phase, mod, average = r.phase, r.modulation, r.average
    phase = np.asarray(phase, np.float64) - group.shifts[0]  # frame k has phase phi + shift
    phase -= (2 * np.pi) * np.round(phase / (2 * np.pi))  # wrapped to [-pi, pi] without complex temporaries
    return PhaseResult(phase.astype(np.float32), np.asarray(average, np.float32), mod.astype(np.float32)), saturated


def ftp_lobe_angle(ctx: DecodeContext, group: PhaseGroup) -> float:
    """Camera-image direction (rad, ``cos`` along rows v, ``sin`` along columns u) in which the
    absolute phase of ``group`` increases; FTP keeps the spectral lobe on that side.

    A single fringe image cannot tell phi from -phi. With a rig, the direction is the camera
    gradient of the projector fringe coordinate ``w`` at the image centre, on a point at depth
    ``z_min`` (or where the camera and projector axes pass closest). Without a rig the camera
    is assumed to see the projector unmirrored (direction = the fringe angle). The decoder
    option ``ftp_sign=-1`` flips the result (e.g. a mirrored rig without calibration).
    """
    angle = group.angle
    if ctx.rig is not None:
        try:
            angle = camera_fringe_direction(ctx.rig, group.angle, ctx.frames.shape[1:], ctx.z_min)
        except Exception as e:  # an unusual rig model: fall back to the unmirrored assumption
            warnings.warn(f"could not orient FTP from the rig ({type(e).__name__}: {e}); assuming an "
                          "unmirrored view (decode option ftp_sign=-1 flips it)", CalibrationWarning, stacklevel=3)
    if ctx.options.ftp_sign < 0:
        angle += np.pi
    return float(angle)


def camera_fringe_direction(rig: Rig, angle: float, shape: tuple[int, int], z_min: float | None) -> float:
    """Camera-image direction (rad) in which the projector fringe coordinate ``w`` of fringe
    ``angle`` grows at the image centre (``shape`` (H, W)), on the point of the central ray at
    depth ``z_min`` or, if None, where that ray passes closest to the projector's axis."""
    h, w = shape
    uv = np.array([[0.5 * (w - 1), 0.5 * (h - 1)], [0.5 * (w - 1) + 1.0, 0.5 * (h - 1)],
                   [0.5 * (w - 1), 0.5 * (h - 1) + 1.0]])
    origins, dirs = pixel_rays(rig, uv)
    origins = np.broadcast_to(np.asarray(origins, float), (3, 3))
    dirs = np.broadcast_to(np.asarray(dirs, float), (3, 3))
    if z_min is not None:
        s = float(z_min)
    else:  # where the camera's central ray passes closest to the projector's optical axis
        proj = rig.projector
        c1 = np.asarray(proj.center, float)
        a1 = np.asarray(proj.R, float)[2]
        d0 = dirs[0]
        w0 = origins[0] - c1
        a, b, c = d0 @ d0, d0 @ a1, a1 @ a1
        den = a * c - b * b
        s = (b * (a1 @ w0) - c * (d0 @ w0)) / den if abs(den) > 1e-12 else 1000.0
        if not s > 0:
            s = 1000.0
    pts = origins + s * dirs
    up = np.asarray(rig.projector.project(pts), float)
    wp = fringe_coordinate(up[:, 0], up[:, 1], angle)
    gu, gv = wp[1] - wp[0], wp[2] - wp[0]
    if not (np.isfinite(gu) and np.isfinite(gv)) or gu == gv == 0:
        raise ValueError("the projector coordinate does not change across the camera image centre")
    return float(np.arctan2(gu, gv))


def require_geometry(ctx: DecodeContext, method: str) -> tuple[RigGeometry, float]:
    """(the rig's :class:`RigGeometry`, z_min) for a method that needs the geometric constraint, with clear errors when
    the decoder lacks them; ``z_min`` from the options or the plan's ``options["z_min"]``."""
    if ctx.rig is None or ctx.geometry is None:
        raise ValueError(f"direction {ctx.direction!r}: method {method!r} needs the calibrated rig "
                         "(pass `rig`)")
    z_min = ctx.z_min if ctx.z_min is not None else ctx.plan.options.get("z_min")
    if z_min is None:
        raise ValueError(f"direction {ctx.direction!r}: method {method!r} needs z_min, the nearest depth of the "
                         "measurement volume in mm (pass `z_min`, or set it in the plan's options)")
    check_camera_size(ctx.frames.shape[1:], camera_shape(ctx.rig))
    return ctx.geometry, float(z_min)


def intensity_noise(ctx: DecodeContext) -> float:
    """Noise sigma (frames' units) of one sample, for the clipping test: Immerkaer's Laplacian
    estimate (:func:`fringe3d.phase.noise.laplacian_noise`) of the first phase-shifted group's
    average over its unclipped pixels, times ``sqrt(N)`` (the average carries ``sigma /
    sqrt(N)``), at least the quantisation noise ``1 / sqrt(12)`` count; cached per direction."""
    if "intensity_noise" not in ctx.cache:
        level = quality.saturation_level(ctx.frames, ctx.bit_depth)
        sigma = 1.0 / np.sqrt(12.0)
        groups = [g for g in ctx.phase_groups() if len(g.indices) >= 3]
        if groups:
            idx = list(groups[0].indices)
            sel = ctx.frames[idx]
            average = sel.mean(axis=0, dtype=np.float32)
            keep = ~(sel >= level).any(axis=0) & (average > 0)
            est = noise.laplacian_noise(average, keep) * np.sqrt(len(idx))
            if np.isfinite(est):
                sigma = max(sigma, float(est))
        ctx.cache["intensity_noise"] = float(sigma)
    return float(ctx.cache["intensity_noise"])


def clipping_broken(ctx: DecodeContext, group: PhaseGroup, order_only: bool = False) -> np.ndarray:
    """(H, W) bool: pixels of a group of 3 or more steps whose phase clipping biases by more than
    the decode option ``max_clip_bias`` (rad), by default the pixel's phase-noise sigma
    ``sqrt(2/N) sigma / B`` with ``sigma`` from :func:`intensity_noise`
    (:func:`fringe3d.phase.clipping.clipping_mask`); cached.

    ``order_only``: the group only picks fringe orders (a coarser group of a multi-frequency
    plan; its phase is not the result), so its bias matters only where it can change an order:
    the bound is then the decode option ``max_disagreement`` (rad), the residual the
    multi-frequency consistency test (INCONSISTENT, :mod:`fringe3d.decode.edges`) accepts.
    The shares of the group's pixels with a clipped sample and of those masked are recorded in
    ``ctx.cache[("saturation", name)]`` (reported in ``info["quality"][direction]["saturation"]``).
    A group the decoder's fused pass found unclipped (``ctx.cache[("clipped_count", name)]`` 0)
    is not read again: its all-False, read-only flags are also its map."""
    key = ("clipping_broken", group.name, order_only)
    if key not in ctx.cache:
        bound = float(ctx.options.max_disagreement) if order_only else ctx.options.max_clip_bias
        clipped = ctx.cache.get(("clipped", group.name))
        if clipped is not None and ctx.cache.get(("clipped_count", group.name)) == 0:
            # the fused pass counted no clipped pixel: nothing breaks, and its all-False flags are the map
            r = clipping.ClippingMask(clipped, clipped, 0)
            n_clipped = 0
        else:
            level = quality.saturation_level(ctx.frames, ctx.bit_depth)
            r = clipping.clipping_mask(ctx.frames, group.indices, group.shifts, level, lambda: intensity_noise(ctx),
                                       bound, clipped=clipped)
            n_clipped = int(np.count_nonzero(r.clipped))  # count_nonzero: no float pass; the same shares
        ctx.cache[("saturation", group.name)] = {
            "clipped": n_clipped / r.clipped.size,
            "masked": np.count_nonzero(r.broken) / r.broken.size if n_clipped else 0.0,
            "estimated": r.estimated / n_clipped if n_clipped else 0.0,
            "rule": "phase bias of the clipped samples > " + (
                f"{bound:g} rad" + (" (fringe order only)" if order_only else "") if bound is not None
                else "phase-noise sigma" + (f" (intensity noise {intensity_noise(ctx):.3g})" if n_clipped else ""))}
        ctx.cache[key] = r.broken
    return ctx.cache[key]


def not_saturated(ctx: DecodeContext, indices) -> np.ndarray:
    """(H, W) bool: no frame of ``indices`` reaches the sensor's saturation level."""
    level = quality.saturation_level(ctx.frames, ctx.bit_depth)
    if not np.isfinite(level):
        return np.ones(ctx.frames.shape[1:], bool)
    return np.asarray(~(ctx.frames[list(indices)] >= level).any(axis=0))


def combined_mask(ctx: DecodeContext, groups: list[PhaseGroup]) -> np.ndarray:
    """(H, W) bool: the first group's :meth:`DecodeContext.group_mask` (its phase is the
    result) and the others' modulation threshold and clipping test for fringe orders
    (:func:`clipping_broken` with ``order_only``)."""
    mask = ctx.group_mask(groups[0])
    for g in groups[1:]:
        pr = ctx.group_phase(g)
        mask = mask & (pr.modulation >= ctx.min_modulation)
        mask &= ~(clipping_broken(ctx, g, order_only=True) if len(g.indices) >= 3 else ctx.group_saturated(g))
    return mask
