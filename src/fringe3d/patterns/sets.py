"""Pattern-set builders: each returns a :class:`PatternSet` with its frames and unwrapping plans.

Conventions every builder follows (the decoder relies on them):

* Directions: ``"v"`` = vertical stripes, angle pi/2, phase encodes the projector column
  ``u_p``; ``"h"`` = horizontal stripes, angle 0, encodes ``v_p``; any other label needs an
  explicit ``angle`` (radians, taken modulo pi).
* Phase frames: ``kind`` in sinusoid/square/bayer/floyd_steinberg/area_modulated/pwm,
  ``role="phase"``, ``period`` T (px, any positive float), ``steps`` N, ``step`` k,
  ``shift = 2*pi*k/N`` (also for N = 3), ``group = f"{direction}/T{T:g}"``. Intensity
  ``1/2(1 + cos(2 pi w / T + shift))``, ``w = v cos(angle) + u sin(angle)`` (Eq. 2.1-2.2), so the
  N-step phase (Eq. 2.4) equals ``Phi = 2 pi w / T`` modulo 2 pi.
* Single-frame FTP: ``steps=1, step=0, shift=0``; modified FTP: ``steps=2`` with shifts 0 and pi.
  Which phase algorithm applies is in the plan's ``options["phase"]``: ``"psp"`` (N-step least
  squares), ``"ftp"``, ``"modified_ftp"``, ``"none"`` (no phase frames), or for the hybrid
  set ``"ftp+psp"``.
* Code frames: ``kind="gray_code"`` or ``"binary_code"``, ``role="code"``, ``period`` = stripe
  width, ``bit`` (0 = MSB) of ``bits``, an ``inverse=True`` copy right after each bit,
  ``group = f"{direction}/gray"`` (or ``/binary``). Codeword ``c`` labels the stripe
  ``[w0 + c*period, w0 + (c+1)*period)`` with ``w0 = options["order_offset"] * period``
  (0 whenever ``angle`` is in [0, pi/2]). For :func:`gray_code` the stripe width is the fringe
  period, so ``k = c + order_offset`` in ``Phi = (phi mod 2pi) + 2 pi k``; the plan's
  ``options["code_period"]`` of :func:`psp_with_gray_code` says how wide its stripes are.
* Reference frames: the white frame has ``kind="white", role="texture", direction=""``.
* Every plan's ``options["w_range"] = [w_min, w_max]``: the fringe coordinates the projector
  covers, so unwrapping knows where the unambiguous window starts (w_min < 0 only for angles
  above pi/2).
"""
from __future__ import annotations

import dataclasses
import math

from fringe3d.patterns.codes import bits_needed
from fringe3d.patterns.conventions import beat_period, w_range
from fringe3d.patterns.manifest import DirectionPlan, FrameSpec, PatternSet
from fringe3d.patterns.render import BINARY_PHASE_KINDS, PHASE_KINDS, code_origin

#: Default projector resolution (pixels). 800 x 600 keeps the 18/21/144 heterodyne set
#: (equivalent period 1008 px) unambiguous in both directions.
DEFAULT_WIDTH = 800
DEFAULT_HEIGHT = 600
DIRECTION_ANGLES = {"v": math.pi / 2, "h": 0.0}
#: The dissertation's three-frequency periods (ch. 2.2.4): beats 126 px and 1008 px.
DISSERTATION_PERIODS = (18.0, 21.0, 144.0)
#: The dissertation's hierarchical periods (18 / 144 / 1024 px).
HIERARCHICAL_PERIODS = (18.0, 144.0, 1024.0)
#: Adapted defaults leave the unambiguous period this much longer than the projector's span
#: (span <= HEADROOM * period), so noise at the far edge does not wrap.
HEADROOM = 0.9


# -- helpers -----------------------------------------------------------------------
def direction_angle(direction: str, angle: float | None = None) -> float:
    """Fringe angle in [0, pi) for ``direction`` (``angle`` in radians overrides)."""
    if angle is None:
        if direction not in DIRECTION_ANGLES:
            raise ValueError(f"direction {direction!r} needs an explicit angle; "
                             f"known directions are {sorted(DIRECTION_ANGLES)}")
        return DIRECTION_ANGLES[direction]
    a = math.fmod(float(angle), math.pi)
    if a < 0:
        a += math.pi
    if a >= math.pi - 1e-12:
        a = 0.0
    return a


def _bit_depth(kind: str, bit_depth: int | None) -> int:
    if kind not in PHASE_KINDS:
        raise ValueError(f"phase pattern kind must be one of {PHASE_KINDS}, got {kind!r}")
    if bit_depth is None:
        return 1 if kind in BINARY_PHASE_KINDS else 8
    if bit_depth == 1 and kind not in BINARY_PHASE_KINDS:
        raise ValueError(f"1-bit output needs a binary kind {BINARY_PHASE_KINDS}, got {kind!r}")
    return bit_depth


def group_name(direction: str, period: float) -> str:
    return f"{direction}/T{period:g}"


def phase_frames(period: float, steps: int, direction: str, angle: float, kind: str = "sinusoid",
                 shifts: list[float] | None = None) -> tuple[FrameSpec, ...]:
    """N phase-shifted frames ``shift_k = 2 pi k / N`` (or the given ``shifts``)."""
    if not (period > 0 and math.isfinite(period)):
        raise ValueError(f"fringe period must be a finite number > 0, got {period}")
    if steps < 1:
        raise ValueError(f"phase-shift steps must be >= 1, got {steps}")
    if shifts is None:
        shifts = [2.0 * math.pi * k / steps for k in range(steps)]
    return tuple(FrameSpec(kind=kind, role="phase", direction=direction, angle=angle, period=float(period),
                           shift=float(s), step=k, steps=steps, group=group_name(direction, period))
                 for k, s in enumerate(shifts))


def w_range_option(angle: float, width: int, height: int) -> list[float]:
    """A plan's ``options["w_range"]``: ``[w_min, w_max]`` of :func:`~fringe3d.patterns.conventions.w_range`
    as a JSON list."""
    lo, hi = w_range(angle, width, height)
    return [lo, hi]


def _check_size(width: int, height: int) -> None:
    if int(width) != width or int(height) != height or width <= 0 or height <= 0:
        raise ValueError(f"projector size must be positive integers, got {width}x{height}")


def fringe_span(direction: str, angle: float | None, width: int, height: int) -> float:
    """``w_max - w_min`` (px): the extent of the fringe coordinate over the projector (Eq. 2.1)."""
    lo, hi = w_range(direction_angle(direction, angle), width, height)
    return hi - lo


def default_three_frequency_periods(span: float) -> tuple[float, float, float]:
    """Default heterodyne periods for a projector whose fringe coordinate spans ``span`` px.

    The dissertation's 18 / 21 / 144 px (ch. 2.2.4: ``T12 = T1 T2 / (T2 - T1) = 126``,
    ``T123 = T12 T3 / (T3 - T12) = 1008``) whenever ``1008 > span``, so every set up to 1008 px
    is unchanged. For a wider span the measuring pair 18 / 21 (and so the phase noise of the
    measurement and ``T12 = 126``) stays, and ``T3`` is the largest whole period whose beat with
    ``T12`` covers the span with headroom, ``T123 >= span / HEADROOM``:
    ``T3 = ceil(T12 X / (X - T12)) - 1`` with ``X = span / HEADROOM`` (e.g. 1280 px -> 138,
    ``T123 = 1449``; 1920 px -> 133, ``T123 = 2394``).

    Examples
    --------
    >>> default_three_frequency_periods(799.0), default_three_frequency_periods(1919.0)
    ((18.0, 21.0, 144.0), (18.0, 21.0, 133.0))
    """
    t1, t2, t3 = DISSERTATION_PERIODS
    t12 = beat_period(t1, t2)
    if beat_period(t12, t3) > span:
        return DISSERTATION_PERIODS
    need = span / HEADROOM
    t3_new = math.ceil(t12 * need / (need - t12)) - 1
    if t3_new <= t12:
        raise ValueError(f"a projector span of {span:g} px is too wide for an 18/21/T3 heterodyne set; "
                         "give the periods explicitly")
    return t1, t2, float(t3_new)


def default_hierarchical_periods(span: float) -> tuple[float, float, float]:
    """Default hierarchical periods: the dissertation's 18 / 144 / 1024 px when
    ``span <= HEADROOM * 1024`` (the single coarse fringe must not wrap under noise at the far
    edge, which a bare ``1024 > span`` allows), else 18 / 144 / the smallest multiple of 128 px
    that is ``>= span / HEADROOM``.

    Examples
    --------
    >>> default_hierarchical_periods(799.0), default_hierarchical_periods(1919.0)
    ((18.0, 144.0, 1024.0), (18.0, 144.0, 2176.0))
    """
    if span <= HEADROOM * HIERARCHICAL_PERIODS[-1]:
        return HIERARCHICAL_PERIODS
    return HIERARCHICAL_PERIODS[0], HIERARCHICAL_PERIODS[1], 128.0 * math.ceil(span / HEADROOM / 128.0)


# -- builders ----------------------------------------------------------------------
def phase_shift(period: float, steps: int = 3, direction: str = "v", angle: float | None = None,
                kind: str = "sinusoid", width: int = DEFAULT_WIDTH, height: int = DEFAULT_HEIGHT,
                bit_depth: int | None = None) -> PatternSet:
    """One N-step phase-shifted set (Eq. 2.2); plan method ``"none"`` (wrapped phase only).

    Examples
    --------
    >>> ps = phase_shift(16, 3, "v", width=32, height=8)
    >>> len(ps), ps.plans[0].method, ps.plans[0].options["w_range"]
    (3, 'none', [0.0, 31.0])
    """
    _check_size(width, height)
    if steps < 3:
        raise ValueError(f"N-step phase shifting needs N >= 3, got {steps}")
    a = direction_angle(direction, angle)
    frames = phase_frames(period, steps, direction, a, kind)
    plan = DirectionPlan(direction, a, "none", (float(period),),
                         {"phase": "psp", "w_range": w_range_option(a, width, height)})
    return PatternSet(width, height, frames, (plan,), _bit_depth(kind, bit_depth),
                      f"phase-shift-{steps}step-T{period:g}-{direction}")


def three_frequency(direction: str = "v", periods=None, steps=(9, 3, 3),
                    angle: float | None = None, kind: str = "sinusoid", width: int = DEFAULT_WIDTH,
                    height: int = DEFAULT_HEIGHT, bit_depth: int | None = None) -> PatternSet:
    """Three-frequency heterodyne set: 9-step T=18 + 3-step T=21 + 3-step T=144 (15 frames).

    T1, T2 beat to ``T12 = T1 T2/(T2-T1)`` (126), T12 and T3 to ``T123`` (1008), which must
    span the projector's fringe coordinates. ``periods=None`` picks
    :func:`default_three_frequency_periods` for this direction's span (18/21/144 up to 1008 px).
    Plan ``"heterodyne"``, ``periods`` as given (narrowest first),
    ``options["beats"] = [[T1, T2, T12], [T12, T3, T123]]``.
    """
    _check_size(width, height)
    a = direction_angle(direction, angle)
    if periods is None:
        periods = default_three_frequency_periods(fringe_span(direction, a, width, height))
    if len(periods) != 3 or len(steps) != 3:
        raise ValueError(f"three-frequency needs 3 periods and 3 step counts, got {periods}, {steps}")
    t1, t2, t3 = (float(t) for t in periods)
    t12 = beat_period(t1, t2)
    t123 = beat_period(t12, t3)
    lo, hi = w_range(a, width, height)
    if hi - lo >= t123:
        raise ValueError(f"three-frequency periods {periods} beat to {t123:g} px, but the projector "
                         f"spans {hi - lo:g} px along the fringe coordinate; choose periods with a "
                         f"larger equivalent period or a smaller projector")
    frames = sum((phase_frames(t, n, direction, a, kind) for t, n in zip((t1, t2, t3), steps)), ())
    plan = DirectionPlan(direction, a, "heterodyne", (t1, t2, t3),
                         {"phase": "psp", "steps": list(steps), "beats": [[t1, t2, t12], [t12, t3, t123]],
                          "w_range": [lo, hi]})
    return PatternSet(width, height, frames, (plan,), _bit_depth(kind, bit_depth),
                      f"three-frequency-{t1:g}-{t2:g}-{t3:g}-{direction}")


def hierarchical(periods, steps, direction: str = "v", angle: float | None = None, kind: str = "sinusoid",
                 width: int = DEFAULT_WIDTH, height: int = DEFAULT_HEIGHT,
                 bit_depth: int | None = None) -> PatternSet:
    """Hierarchical multi-frequency set: the coarsest period covers the projector (single
    fringe, absolute phase) and each phase unwraps the next narrower one (Eq. 1.5).

    ``steps`` is one count or one per period. Frames in the given order; plan periods sorted
    narrowest first.
    """
    _check_size(width, height)
    periods = [float(t) for t in periods]
    steps = [int(steps)] * len(periods) if isinstance(steps, int) else [int(n) for n in steps]
    if len(periods) < 2 or len(steps) != len(periods):
        raise ValueError(f"hierarchical needs >= 2 periods and one step count each, got {periods}, {steps}")
    if any(n < 3 for n in steps):
        raise ValueError(f"hierarchical unwrapping uses N-step phases with N >= 3, got steps {steps}")
    a = direction_angle(direction, angle)
    lo, hi = w_range(a, width, height)
    if max(periods) <= hi - lo:
        raise ValueError(f"the coarsest period {max(periods):g} px must exceed the projector's span "
                         f"{hi - lo:g} px along the fringe coordinate to give absolute phase")
    frames = sum((phase_frames(t, n, direction, a, kind) for t, n in zip(periods, steps)), ())
    plan = DirectionPlan(direction, a, "hierarchical", tuple(sorted(periods)),
                         {"phase": "psp", "w_range": [lo, hi]})
    return PatternSet(width, height, frames, (plan,), _bit_depth(kind, bit_depth),
                      "hierarchical-" + "-".join(f"{t:g}" for t in periods) + f"-{direction}")


def _code_frames(period: float, direction: str, a: float, width: int, height: int, code: str,
                 inverse: bool) -> tuple[tuple[FrameSpec, ...], dict]:
    if code not in ("gray", "binary"):
        raise ValueError(f"code must be 'gray' or 'binary', got {code!r}")
    if not period > 0:
        raise ValueError(f"code stripe period must be positive, got {period}")
    w0, stripes = code_origin(a, width, height, float(period))
    bits = bits_needed(stripes)
    kind = "gray_code" if code == "gray" else "binary_code"
    group = f"{direction}/{code}"
    frames = []
    for b in range(bits):
        for inv in ((False, True) if inverse else (False,)):
            frames.append(FrameSpec(kind=kind, role="code", direction=direction, angle=a, period=float(period),
                                    bit=b, bits=bits, inverse=inv, group=group))
    opts = {"code": code, "code_group": group, "bits": bits, "inverse": inverse,
            "order_offset": int(round(w0 / period)), "w_range": w_range_option(a, width, height)}
    return tuple(frames), opts


def gray_code(period: float, direction: str = "v", angle: float | None = None, width: int = DEFAULT_WIDTH,
              height: int = DEFAULT_HEIGHT, code: str = "gray", inverse: bool = True) -> PatternSet:
    """Gray-code (or simple binary, ``code="binary"``) stripes of width ``period`` with inverse frames.

    Codeword c labels stripe ``[w0 + c T, w0 + (c+1) T)``; enough bits to cover the projector.
    Plan method ``"gray_code"``/``"binary_code"`` with ``options["phase"] = "none"`` (stripe
    index only); combine with phase frames via :func:`psp_with_gray_code`. 1-bit set.
    """
    _check_size(width, height)
    a = direction_angle(direction, angle)
    frames, opts = _code_frames(period, direction, a, width, height, code, inverse)
    plan = DirectionPlan(direction, a, f"{code}_code", (float(period),), {"phase": "none", **opts})
    return PatternSet(width, height, frames, (plan,), 1, f"{code}-code-T{period:g}-{direction}")


def binary_code(period: float, direction: str = "v", **kw) -> PatternSet:
    """Simple binary code stripes with inverse frames (see :func:`gray_code`)."""
    return gray_code(period, direction, code="binary", **kw)


@dataclasses.dataclass(frozen=True)
class CodeFrames:
    """The code frames of :func:`psp_with_gray_code`.

    Attributes
    ----------
    code : str
        ``"gray"`` (Gray code) or ``"binary"`` (simple binary code).
    inverse : bool
        An inverse copy right after each code bit's frame (the decoder thresholds a bit against
        its inverse).
    period : float | None
        Stripe width (projector px); ``None``: half the fringe period.
    """

    code: str = "gray"
    inverse: bool = True
    period: float | None = None


def psp_with_gray_code(period: float, steps: int = 3, direction: str = "v", angle: float | None = None,
                       kind: str = "sinusoid", width: int = DEFAULT_WIDTH, height: int = DEFAULT_HEIGHT,
                       bit_depth: int | None = None, code: CodeFrames | None = None) -> PatternSet:
    """N-step phase frames followed by code frames (plan ``"gray_code"``).

    ``code`` (:class:`CodeFrames`) says which code, with or without inverse frames, and its
    stripe width ``code.period``; the default ``period / 2`` resolves half
    fringe periods (one bit more than a period-wide code, the complementary Gray code): a
    decoder that rounds ``(2 pi c / T - phi) / 2 pi`` against the stripe centre ``c`` then
    tolerates stripe edges misplaced by up to T/4. With ``code.period = period`` the codeword
    is the fringe order itself, but its stripe edges coincide with phase 0 of every fringe: the
    decoder takes the order of the edge whose code bit fades, exact without noise, yet a pixel
    within noise of an edge can take the neighbouring order (measured in ``fringe3d experiment
    unwrap-noise``). Code frames carry the stripe width in ``period``.
    """
    if code is None:
        code = CodeFrames()
    elif not isinstance(code, CodeFrames):
        raise TypeError(f"code must be a CodeFrames (code, inverse, period), got {code!r}")
    ps = phase_shift(period, steps, direction, angle, kind, width, height, bit_depth)
    a = ps.plans[0].angle
    cp = float(period / 2.0 if code.period is None else code.period)
    cframes, opts = _code_frames(cp, direction, a, width, height, code.code, code.inverse)
    opts["code_period"] = cp
    plan = DirectionPlan(direction, a, f"{code.code}_code", (float(period),), {"phase": "psp", **opts})
    return PatternSet(width, height, ps.frames + cframes, (plan,), ps.bit_depth,
                      f"psp-{steps}step-{code.code}-T{period:g}-{direction}")


def ftp(period: float, direction: str = "v", angle: float | None = None, kind: str = "sinusoid",
        width: int = DEFAULT_WIDTH, height: int = DEFAULT_HEIGHT, method: str = "none",
        bit_depth: int | None = None) -> PatternSet:
    """Single-frame Fourier-transform profilometry set (Eq. 4.1-4.4); ``options["phase"]="ftp"``.

    ``method`` is the unwrapping the plan names (``"none"`` = wrapped phase only, or
    ``"spatial"``, ``"geometric"``, ``"histogram"``).
    """
    _check_size(width, height)
    a = direction_angle(direction, angle)
    frames = phase_frames(period, 1, direction, a, kind, shifts=[0.0])
    plan = DirectionPlan(direction, a, method, (float(period),),
                         {"phase": "ftp", "w_range": w_range_option(a, width, height)})
    return PatternSet(width, height, frames, (plan,), _bit_depth(kind, bit_depth), f"ftp-T{period:g}-{direction}")


def modified_ftp(period: float, direction: str = "v", angle: float | None = None, kind: str = "sinusoid",
                 width: int = DEFAULT_WIDTH, height: int = DEFAULT_HEIGHT, method: str = "none",
                 bit_depth: int | None = None) -> PatternSet:
    """π-shifted pair for modified FTP (Eq. 4.5-4.7, 6.1-6.6); ``options["phase"]="modified_ftp"``."""
    _check_size(width, height)
    a = direction_angle(direction, angle)
    frames = phase_frames(period, 2, direction, a, kind, shifts=[0.0, math.pi])
    plan = DirectionPlan(direction, a, method, (float(period),),
                         {"phase": "modified_ftp", "w_range": w_range_option(a, width, height)})
    return PatternSet(width, height, frames, (plan,), _bit_depth(kind, bit_depth),
                      f"modified-ftp-T{period:g}-{direction}")


def two_frequency(high_period: float, low_period: float, direction: str = "v", angle: float | None = None,
                  kind: str = "sinusoid", width: int = DEFAULT_WIDTH, height: int = DEFAULT_HEIGHT,
                  bit_depth: int | None = None) -> PatternSet:
    """Enhanced two-frequency PSP (ch. 5.3): 3-step low frequency then 3-step high frequency.

    Plan ``"two_frequency_geometric"``, periods ``(high, low)``: the low phase is unwrapped by
    the geometric constraint (Eq. 4.21) and then unwraps the high phase. 6 frames.
    """
    _check_size(width, height)
    if not low_period > high_period:
        raise ValueError(f"low_period ({low_period}) must exceed high_period ({high_period})")
    a = direction_angle(direction, angle)
    frames = phase_frames(low_period, 3, direction, a, kind) + phase_frames(high_period, 3, direction, a, kind)
    plan = DirectionPlan(direction, a, "two_frequency_geometric", (float(high_period), float(low_period)),
                         {"phase": "psp", "w_range": w_range_option(a, width, height)})
    return PatternSet(width, height, frames, (plan,), _bit_depth(kind, bit_depth),
                      f"two-frequency-{high_period:g}-{low_period:g}-{direction}")


def hybrid(high_period: float, low_period: float, direction: str = "v", angle: float | None = None,
           kind: str = "sinusoid", width: int = DEFAULT_WIDTH, height: int = DEFAULT_HEIGHT,
           bit_depth: int | None = None) -> PatternSet:
    """Hybrid FTP + PSP (ch. 5.2.5): 3-step low-frequency frames, then one high-frequency frame.

    Plan ``"hybrid"``, periods ``(high, low)``, ``options["phase"] = "ftp+psp"``: FTP on the
    last (high) frame, 3-step PSP + geometric constraint on the low group (Eq. 5.13-5.15).
    """
    _check_size(width, height)
    if not low_period > high_period:
        raise ValueError(f"low_period ({low_period}) must exceed high_period ({high_period})")
    a = direction_angle(direction, angle)
    frames = phase_frames(low_period, 3, direction, a, kind) + phase_frames(high_period, 1, direction, a, kind,
                                                                            shifts=[0.0])
    plan = DirectionPlan(direction, a, "hybrid", (float(high_period), float(low_period)),
                         {"phase": "ftp+psp", "high_group": group_name(direction, high_period),
                          "low_group": group_name(direction, low_period), "w_range": w_range_option(a, width, height)})
    return PatternSet(width, height, frames, (plan,), _bit_depth(kind, bit_depth),
                      f"hybrid-{high_period:g}-{low_period:g}-{direction}")


def white_frame() -> FrameSpec:
    """All-on reference frame (board image / texture)."""
    return FrameSpec(kind="white", role="texture")


def calibration(width: int = DEFAULT_WIDTH, height: int = DEFAULT_HEIGHT, directions=("v", "h"),
                periods=None, steps=(9, 3, 3), kind: str = "sinusoid",
                bit_depth: int | None = None) -> PatternSet:
    """Calibration sequence per board pose (ch. 2.2.4): white frame + the 15-frame
    three-frequency set for each direction (31 frames for ``("v", "h")``); ``periods=None``
    adapts per direction (:func:`default_three_frequency_periods`: 18/21/144 up to 1008 px)."""
    _check_size(width, height)
    frames = [white_frame()]
    plans: list[DirectionPlan] = []
    for d in directions:
        ps = three_frequency(d, periods, steps, kind=kind, width=width, height=height, bit_depth=bit_depth)
        frames += ps.frames
        plans += ps.plans
    return PatternSet(width, height, tuple(frames), tuple(plans), _bit_depth(kind, bit_depth),
                      "calibration-" + "".join(directions))


def optimal_angle_calibration(alpha_opt: float, width: int = DEFAULT_WIDTH, height: int = DEFAULT_HEIGHT,
                              periods=None, steps=(9, 3, 3), kind: str = "sinusoid",
                              bit_depth: int | None = None) -> PatternSet:
    """Optimal-angle calibration (Eq. 2.32-2.34): white + 15 frames at ``alpha_opt - pi/4``
    (direction ``"a1"``) + 15 at ``alpha_opt + pi/4`` (``"a2"``), angles taken modulo pi.
    31 frames; each plan carries ``options["alpha_opt"]``; ``periods=None`` adapts per direction
    as in :func:`calibration`."""
    _check_size(width, height)
    frames = [white_frame()]
    plans: list[DirectionPlan] = []
    for d, off in (("a1", -math.pi / 4), ("a2", math.pi / 4)):
        ps = three_frequency(d, periods, steps, angle=direction_angle(d, alpha_opt + off), kind=kind,
                             width=width, height=height, bit_depth=bit_depth)
        frames += ps.frames
        p = ps.plans[0]
        plans.append(DirectionPlan(p.direction, p.angle, p.method, p.periods,
                                   {**p.options, "alpha_opt": float(alpha_opt)}))
    return PatternSet(width, height, tuple(frames), tuple(plans), _bit_depth(kind, bit_depth),
                      f"optimal-angle-calibration-{math.degrees(alpha_opt):g}deg")


def binary_fine_calibration(width: int, height: int, steps=(9, 3, 3)) -> PatternSet:
    """Calibration set with a squared-binary measuring phase (binary defocusing, ch. 5.3).

    White frame + per direction (``"v"``, ``"h"``) the three-frequency groups of
    :func:`calibration`: the ``T = 18`` measuring group as 1-bit squared binary fringes, the
    ``T = 21`` / ``T = 144`` unwrapping groups as 8-bit sinusoids. (3-step squared binary at
    T = 21 / 144 aliases its 5th / 7th harmonics into +-0.2 rad phase errors that break the
    heterodyne unwrapping while the projector is in focus; the measuring T = 18 phase stays
    binary.)

    Parameters
    ----------
    width, height : int
        Projector size (px).
    steps : (3,) int
        Phase steps of the T = 18, 21, 144 groups.

    Returns
    -------
    PatternSet
        ``1 + 2 * sum(steps)`` frames, bit depth 8, name ``"calibration-square18-sine21-144"``.
    """
    base = calibration(width=width, height=height, kind="square", steps=steps)
    frames = tuple(dataclasses.replace(f, kind="sinusoid") if (f.kind == "square" and f.period != 18) else f
                   for f in base.frames)
    return dataclasses.replace(base, frames=frames, bit_depth=8, name="calibration-square18-sine21-144")


def binary_modified_ftp(width: int, height: int) -> PatternSet:
    """The 1-bit five-image cycle of the flapping-wing measurement (ch. 6).

    A 3-step Floyd-Steinberg dithered ``T = 380`` set for the histogram (fringe-order mode)
    unwrapping, then the pi-shifted area-modulated ``T = 24`` pair for modified FTP
    (Eq. 6.1-6.6), vertical fringes (``w = u``).

    Parameters
    ----------
    width, height : int
        Projector size (px); the plan's ``w_range`` covers it.

    Returns
    -------
    PatternSet
        5 frames, bit depth 1, one ``"histogram"`` plan with ``options["phase"] = "modified_ftp"``.
    """
    a = direction_angle("v")
    frames = phase_frames(380, 3, "v", a, "floyd_steinberg") + \
        phase_frames(24, 2, "v", a, "area_modulated", shifts=[0.0, math.pi])
    plan = DirectionPlan("v", a, "histogram", (24.0, 380.0),
                         {"phase": "modified_ftp", "w_range": w_range_option(a, width, height)})
    return PatternSet(width, height, frames, (plan,), 1, "ch6-modified-ftp-T24-dithered-T380")


def binary_psp(width: int, height: int) -> PatternSet:
    """Diagnostic 1-bit cycle without FTP for the flapping wing (ch. 6): the 3-step dithered
    ``T = 380`` set of :func:`binary_modified_ftp` plus a 4-step area-modulated ``T = 24``
    phase-shifting set, to tell modified-FTP errors from pattern/sensor errors.

    Parameters
    ----------
    width, height : int
        Projector size (px).

    Returns
    -------
    PatternSet
        7 frames, bit depth 1, one ``"histogram"`` plan (N-step phase).
    """
    a = direction_angle("v")
    frames = phase_frames(380, 3, "v", a, "floyd_steinberg") + phase_frames(24, 4, "v", a, "area_modulated")
    plan = DirectionPlan("v", a, "histogram", (24.0, 380.0), {"w_range": w_range_option(a, width, height)})
    return PatternSet(width, height, frames, (plan,), 1, "diag-psp4-T24-dithered-T380")
