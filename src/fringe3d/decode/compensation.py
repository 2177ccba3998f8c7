"""Projector-nonlinearity compensation and diagnosis of a phase group (issue 25).

:class:`~fringe3d.decode.options.DecodeOptions` ``compensate``:

* ``"response"``: the phase-error table (Zhang & Yau 2007) of the measured response
  ``DecodeOptions.response`` (:class:`fringe3d.radiometry.ResponseLUT`, e.g. from a grey-ramp
  ``gamma.json``) for the group's shifts; any N >= 3.
* ``"harmonic"``: the self-calibrating harmonic model (:mod:`fringe3d.radiometry.harmonics`)
  estimated from the group's own frames; groups of N >= 4 equal steps only (others are left as
  they are and say so in ``Decoded.info["radiometry"]``).
* ``"disagreement"``: the ripple estimated from the disagreement between two frequencies of the
  same N >= 3 equal steps (after Xing & Guo 2018), applied to every such group's wrapped phase
  between two unwrapping passes (:mod:`fringe3d.decode.self_calibration`); 3-step
  multi-frequency captures.

:func:`diagnose_group` runs :func:`fringe3d.radiometry.diagnose` on a subsample of a group of
N >= 4 equal steps, for ``Decoded.info["radiometry"]`` whether or not a compensation is chosen
(with a rig, its ripple also in micrometres on the surface: ``ripple_um``,
:func:`fringe3d.radiometry.ripple_size.mm_per_projector_px`).
"""
from __future__ import annotations

import functools
from typing import Any, Protocol, Sequence

import numba
import numpy as np

from fringe3d.phase.psp import PhaseResult, default_shifts, wrapped_phase
from fringe3d.radiometry import diagnose, disagreement_lut, estimate_gamma, lut_from_response, power_law
from fringe3d.radiometry.phase_error import wrap
from fringe3d.radiometry.ripple_size import mm_per_projector_px
from fringe3d.utils._prefetch import prefetch_lines


class PhaseGroup(Protocol):
    """What this module reads of a :class:`fringe3d.decode.context.PhaseGroup` (a protocol, so
    that the context, which calls this module, is not imported back)."""

    @property
    def name(self) -> str: ...
    @property
    def indices(self) -> Sequence[int]: ...
    @property
    def shifts(self) -> Sequence[float]: ...
    @property
    def period(self) -> float: ...


class DecodeContext(Protocol):
    """What this module reads of a :class:`fringe3d.decode.context.DecodeContext`."""

    frames: Any
    direction: str
    rig: Any
    min_modulation: float
    options: Any
    cache: dict

    def group_phase(self, group: Any) -> PhaseResult: ...
    def groups_for_plan(self) -> list[Any]: ...
    def group_for_period(self, period: float) -> Any: ...

COMPENSATIONS = ("response", "harmonic", "disagreement")
#: Pixels used by the harmonic estimate and the diagnostic (a regular subsample beyond this).
SAMPLE_PIXELS = 16384


def equal_steps(shifts) -> bool:
    """The shifts are ``shift_0 + 2 pi k / N`` in step order (what the harmonic model needs)."""
    return _equal_steps(_shift_key(shifts), 4)


def _shift_key(shifts) -> tuple:
    """``shifts`` as a tuple (a group's own tuple as it is), the key of :func:`_equal_steps`."""
    return shifts if type(shifts) is tuple else tuple(np.asarray(shifts, float).ravel().tolist())


@functools.lru_cache(maxsize=256)
def _equal_steps(shifts: tuple, least: int) -> bool:
    """:func:`equal_steps` (``least`` 4) and :func:`steps_equal` (3) of one tuple of shifts, once
    per set of shifts (the decoder asks per group and cycle)."""
    d = np.asarray(shifts, float)
    return d.size >= least and _near_zero(wrap(d - d[0] - default_shifts(d.size)))


def _near_zero(x: np.ndarray) -> bool:
    """``np.allclose(x, 0.0, atol=1e-6)`` (``|x| <= 1e-6`` everywhere, NaN and inf never) without its
    broadcasting and error-state machinery (the decoder asks once per group and cycle)."""
    return bool(np.all(np.abs(x) <= 1e-6))


def _sample(ctx: DecodeContext, group: PhaseGroup, pr: PhaseResult | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(N, h, w) float32 frames of a regular subsample of at most ~``SAMPLE_PIXELS`` pixels, and
    their (h, w) bool mask modulation >= ``ctx.min_modulation`` (from ``pr`` when given, else the
    subsample's own modulation, so that no full-size phase is computed for a diagnostic)."""
    frames, step = ctx.cache.get(("radiometry_sample", group.name)) or _gathered_sample(ctx, group)
    if pr is not None:
        modulation = pr.modulation[::step, ::step]
    else:  # ~SAMPLE_PIXELS pixels: one thread (a parallel region's fork and join cost more than they save)
        n = numba.get_num_threads()
        numba.set_num_threads(1)  # this thread's own setting
        try:
            modulation = wrapped_phase(frames, shifts=np.asarray(group.shifts, float)).modulation
        finally:
            numba.set_num_threads(n)
    return frames, modulation >= max(ctx.min_modulation, 1e-12)


def _gathered_sample(ctx: DecodeContext, group: PhaseGroup) -> tuple[np.ndarray, int]:
    """The (N, h, w) float32 subsample of :func:`_sample` and its step."""
    h, w = np.shape(ctx.frames[group.indices[0]])[-2:]
    step = max(1, int(np.ceil(np.sqrt(h * w / SAMPLE_PIXELS))))
    return _strided_sample(ctx.frames, group.indices, step), step


def prefetch_sample(ctx: DecodeContext, plan: Any) -> None:
    """Gather the subsample the diagnostic of ``plan``'s narrowest group (:func:`radiometry_info`)
    will read, into ``ctx.cache``, when that group has N >= 4 equal steps: called before the
    direction's method, while the frames are still in the processor's cache (after its passes
    and its outputs, reading them again comes from memory). The same values :func:`_sample`
    gathers otherwise; nothing is done (and nothing raised) for any other plan."""
    groups = ctx.cache.get(("phase_groups",)) or []
    if not groups:
        return
    try:
        g = ctx.group_for_period(plan.periods[0]) if plan.periods else groups[0]
    except ValueError:  # the method says so, in its own words
        return
    if len(g.indices) >= 4 and equal_steps(g.shifts):
        ctx.cache[("radiometry_sample", g.name)] = _gathered_sample(ctx, g)


def _strided_sample(frames: np.ndarray, indices, step: int) -> np.ndarray:
    """(N, h, w) float32 ``frames[i][::step, ::step]`` of each index ``i`` (the strided copies and
    their float32 casts in one compiled gather; numpy's for anything but an (F, H, W) array)."""
    idx = np.asarray(list(indices), np.int64)
    if not isinstance(frames, np.ndarray) or frames.ndim != 3 or not _compiled_dtype(frames.dtype):
        return np.stack([np.asarray(frames[i][::step, ::step], np.float32) for i in idx])
    h, w = frames.shape[1:]
    out = np.empty((idx.size, -(-h // step), -(-w // step)), np.float32)
    _gather(frames, idx, step, out)
    return out


def _compiled_dtype(dtype: np.dtype) -> bool:
    """A dtype the compiled passes read: native integers, float32 or float64."""
    return dtype.isnative and (dtype.kind in "ui" or dtype in (np.float32, np.float64))


#: Sampled rows :func:`_gather` prefetches ahead of the one it reads.
AHEAD = 4


@numba.njit(cache=True)
def _gather(frames, idx, step, out):  # pragma: no cover - compiled
    """``out[k] = frames[idx[k], ::step, ::step]`` as float32, the sampled row :data:`AHEAD`
    rows on (into the next frame at a frame's end) prefetched (strided rows: the hardware
    prefetchers do not follow them)."""
    nr = out.shape[1]
    for k in range(idx.shape[0]):
        for a in range(nr):
            t = k * nr + a + AHEAD
            if t < idx.shape[0] * nr:
                prefetch_lines(frames[idx[t // nr], (t % nr) * step])
            row = frames[idx[k], a * step]
            o = out[k, a]
            for b in range(out.shape[2]):
                o[b] = np.float32(row[b * step])


def diagnose_group(ctx: DecodeContext, group: PhaseGroup, pr: PhaseResult | None = None) -> dict[str, Any] | None:
    """The nonlinearity report (:class:`fringe3d.radiometry.NonlinearityReport` as a dict) of a
    group of N >= 4 equal steps; None for other groups or without usable pixels. It reads a
    subsample of the group's frames only (``pr``, when given, supplies the modulation mask)."""
    if not equal_steps(group.shifts):
        return None
    frames, ok = _sample(ctx, group, pr)
    if ok.sum() < 100:
        return None
    report = {"group": group.name, **diagnose(frames, ok, period=group.period).as_dict()}
    if ctx.rig is not None and report["ripple_px"] is not None:  # on the surface, at the rig's working point
        report["ripple_um"] = report["ripple_px"] * mm_per_projector_px(ctx.rig, ctx.direction) * 1e3
    return report


def compensate_group(ctx: DecodeContext, group: PhaseGroup, pr: PhaseResult) -> tuple[PhaseResult, dict[str, Any]]:
    """The group's phase with ``ctx.options.compensate`` applied, and what was done (JSON-ready)."""
    how = ctx.options.compensate
    info: dict[str, Any] = {"group": group.name, "compensation": how, "applied": False}
    if how == "response":
        lut = lut_from_response(ctx.options.response, shifts=group.shifts)
    elif not equal_steps(group.shifts):
        info["reason"] = (f"the harmonic model needs N >= 4 equally shifted steps; group {group.name!r} has "
                          f"{len(group.shifts)}")
        return pr, info
    else:
        frames, ok = _sample(ctx, group, pr)
        est = estimate_gamma(frames, ok)
        lut = lut_from_response(power_law(est.gamma), shifts=group.shifts)
        info["gamma"] = est.gamma
    info.update(applied=True, ripple_rad=lut.amplitude)
    return PhaseResult(lut.correct(pr.phase), pr.average, pr.modulation), info


def steps_equal(shifts) -> bool:
    """The shifts are N >= 3 steps ``shift_0 + 2 pi k / N`` in step order (what the disagreement needs)."""
    return _equal_steps(_shift_key(shifts), 3)


def disagreement_group(ctx: DecodeContext, group: PhaseGroup, phase: np.ndarray, mask: np.ndarray,
                       threshold_rad: float = 0.005) -> dict[str, Any] | None:
    """The ripple of the plan's narrowest group estimated from its disagreement with another
    group of the plan with as many equal steps (:func:`fringe3d.radiometry.disagreement_lut`,
    after Xing & Guo 2018), from the direction's absolute ``phase`` (rad at the group's period);
    None without such a group or usable pixels. For 3-step multi-frequency captures, where the
    harmonic diagnostic cannot apply."""
    others = [h for h in ctx.groups_for_plan() if h.name != group.name and len(h.indices) == len(group.indices)
              and not np.isclose(h.period, group.period) and steps_equal(h.shifts)]
    if not others or not steps_equal(group.shifts):
        return None
    other = others[0]
    h, w = phase.shape
    step = max(1, int(np.ceil(np.sqrt(h * w / SAMPLE_PIXELS))))
    big = np.asarray(phase[::step, ::step], float)
    ok = np.asarray(mask[::step, ::step], bool) & np.isfinite(big)
    if ok.sum() < 100:
        return None
    if other.name in ctx.cache:  # computed by the decode already
        wrapped_b = np.asarray(ctx.cache[other.name][0].phase[::step, ::step], float)
    else:  # the fused paths never computed it: the subsample's own phase, not a full-size one
        sub = np.stack([np.asarray(ctx.frames[i][::step, ::step], np.float32) for i in other.indices])
        wrapped_b = np.asarray(wrapped_phase(sub, shifts=np.asarray(other.shifts, float)).phase, float)
    ratio = group.period / other.period
    big_b = wrapped_b + 2 * np.pi * np.round((np.where(ok, big, 0.0) * ratio - wrapped_b) / (2 * np.pi))
    amp = disagreement_lut(big, group.period, big_b, other.period, len(group.indices), ok).amplitude
    px = amp * group.period / (2 * np.pi)
    report: dict[str, Any] = {"group": group.name, "method": "disagreement", "with": other.name,
                              "steps": len(group.indices), "ripple_order": len(group.indices), "ripple_rad": amp,
                              "ripple_px": px, "nonlinear": bool(amp > threshold_rad), "fix": None}
    if ctx.rig is not None:
        report["ripple_um"] = px * mm_per_projector_px(ctx.rig, ctx.direction) * 1e3
    if report["nonlinear"]:
        report["fix"] = (f"the projector is nonlinear: the {group.name!r} and {other.name!r} fringes disagree by a "
                         f"ripple {len(group.indices)} times per fringe of up to {amp:.3g} rad = {px:.3g} px; measure "
                         "the response with a grey ramp and decode with `compensate='response'`, or pre-distort the "
                         "patterns")
    return report


def radiometry_info(ctx: DecodeContext, group: PhaseGroup | None, phase: np.ndarray | None = None,
                    mask: np.ndarray | None = None) -> dict[str, Any] | None:
    """``Decoded.info["radiometry"][direction]``: the diagnostic of the plan's narrowest group
    (when it has N >= 4 equal steps; else, given the direction's absolute ``phase`` and ``mask``,
    from its disagreement with another frequency: :func:`disagreement_group`) and what each
    group's compensation did; None when neither."""
    out: dict[str, Any] = {}
    report = None
    if group is not None and len(group.indices) >= 4:
        report = diagnose_group(ctx, group, ctx.cache[group.name][0] if group.name in ctx.cache else None)
    elif group is not None and phase is not None and mask is not None and not ctx.options.compensate:
        report = disagreement_group(ctx, group, phase, mask)
    if report is not None:
        out["diagnostic"] = report
    done = ctx.cache.get("radiometry", {}).get("compensation")
    if done:
        out["compensation"] = done
    return out or None
