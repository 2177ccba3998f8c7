"""Typed decoder options: :class:`DecodeOptions`, what a user passes to ``decode``."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

from fringe3d.unwrap.temporal import MAX_CODE_RESIDUAL


@dataclass(frozen=True)
class DecodeOptions:
    """Options of :func:`fringe3d.decode.decode` and the methods of :data:`fringe3d.decode.METHODS`.

    ``None`` means "not set": the plan's ``options`` (manifest) or the method's default apply.

    Attributes
    ----------
    z_min : float, optional
        Nearest depth of the measurement volume (mm, world frame) for the geometric
        constraint (Eq. 4.15-4.21); the plan's ``options["z_min"]`` if not given.
    z_max : float, optional
        Farthest depth (mm): the geometric methods warn when it exceeds their depth range.
        A plan's ``options["z_max"]`` takes precedence.
    bit_depth : int, optional
        Sensor bit depth (saturation level ``2**bit_depth - 1``); default from the dtype
        (8 / 16), no saturation check for float frames.
    min_modulation : float, optional
        Modulation threshold (frames' units); default 2 % of full scale.
    max_clip_bias : float, optional
        Largest phase bias (rad) that clipped samples may cause before a pixel of a phase
        group is masked (:mod:`fringe3d.phase.clipping`); default the pixel's phase-noise
        sigma ``sqrt(2/N) sigma / B`` (``sigma`` estimated from the capture).
    fused : bool
        Use the fused three-frequency kernel when the plan allows (default True).
    max_residual : float
        Multi-frequency plans: largest accepted unwrapping residual in rad of each step's finer
        phase (default pi/2, a quarter period; ``math.pi`` disables the check). The fused
        three-frequency path masks pixels above it in its own mask; ``hierarchical`` and
        ``heterodyne`` give them the quality bit ``ORDER`` (:mod:`fringe3d.decode.edges`).
    max_code_residual : float
        Code + phase plans (``gray_code`` / ``binary_code`` with phase frames): largest accepted
        distance, in fringe periods, of the unwrapped coordinate from the codeword's stripe
        (default :data:`fringe3d.unwrap.temporal.MAX_CODE_RESIDUAL`, 1/8); pixels beyond it get
        the quality bit ``ORDER`` and are masked (``math.inf`` disables the check).
    ftp_window : str, optional
        FTP band-pass window, ``"hanning"`` or ``"circular"``.
    ftp_radius : float, optional
        FTP band-pass radius (cycles/pixel), see :func:`fringe3d.phase.ftp.ftp_analysis`.
    ftp_sign : int
        ``-1`` flips the FTP lobe the decoder keeps (a mirrored rig without calibration).
    erode, min_size, min_ratio, max_shift, cross_motion :
        Object segmentation and motion options of the ``spatial``, ``histogram`` and
        ``hybrid`` methods (rim erosion in pixels, smallest object in pixels, contrast
        threshold, largest displacement in pixels, cross-fringe motion correction).
    white_thr, black_thr : float, optional
        Code-only decoding (``gray_code_only``): smallest accepted code/inverse difference and
        smallest white - black difference (frames' units); default OpenCV's 5 and 40 counts of
        an 8-bit camera, scaled to the frames' full scale.
    edge_thr : float, optional
        Code-only decoding: smallest code/inverse difference of the one undecided bit of a
        stripe-edge pixel (frames' units; halved without inverses as ``white_thr``); default 2
        counts of an 8-bit camera with inverse frames, 3 without, scaled
        (:mod:`fringe3d.decode.methods.code_only`). 0 keeps every edge pixel.
    sub_stripe : bool, optional
        Code-only decoding with inverse frames: refine the projector coordinate within the
        stripe from the code/inverse zero crossings (:mod:`fringe3d.unwrap.sub_stripe`; default
        True); False gives the stripe centre.
    edge_mask : bool
        Mask edge and mixed pixels (default True; :mod:`fringe3d.decode.edges`): the fringe
        coordinate within ``edge_margin`` of the pattern's extent, multi-frequency phases that
        disagree by more than ``max_disagreement``, phase-gradient jumps and modulation drops.
        Each reason is a bit of ``Decoded.quality``; False keeps only the method's own mask.
        Applies to directions with a phase-shifted group of 3 or more steps and an absolute phase
        (not to code-only, FTP-only or ``method="none"`` directions).
    edge_margin : float, optional
        Width (projector px) of the masked band at the pattern's border; default
        ``2 + 2 sigma_b`` with ``sigma_b`` the blur estimated from two periods' modulation ratio
        (:func:`fringe3d.decode.edges.estimate_blur`; 0 with one period).
    max_disagreement : float
        Largest accepted multi-frequency unwrapping residual (rad of the coarser period, default 0.6).
    gradient_ratio : float
        Phase-gradient test: a jump of ``w`` to a neighbour above this times the local median
        jump (and 1 projector px) is a depth edge (default 4).
    modulation_ratio : float
        Modulation-drop test: fringe contrast ``B / A`` below this share of the largest in the
        5 x 5 neighbourhood (default 0.5).
    rim : int
        Mask this many pixels around every pixel the method's mask removed (silhouette, shadow
        and unlit rims, mixed by the pixel footprint and blur; default 1, 0 turns it off).
    extra : mapping
        Further options for user-added methods (read as ``ctx.options.extra``).
    compensate : {"response", "harmonic", "disagreement"}, optional
        Correct the projector-nonlinearity phase error of every phase-shifted group
        (:mod:`fringe3d.decode.compensation`): ``"response"`` by the phase-error table of
        ``response`` (Zhang & Yau 2007), ``"harmonic"`` by the harmonic model estimated from the
        capture itself (groups of N >= 4 equal steps), ``"disagreement"`` by the ripple estimated
        from two frequencies of the same N >= 3 equal steps, between two unwrapping passes
        (:mod:`fringe3d.decode.self_calibration`; every plan needs such a pair). Turns the fused
        kernel off.
    response : fringe3d.radiometry.ResponseLUT, optional
        The projector's measured response, for ``compensate="response"``.
    backend : {"cpu", "cuda"}
        Where the fused three-frequency decode runs (``"cuda"``: :mod:`fringe3d.gpu`; with a
        narrowest group of 4 or more steps, as the default 15-frame set, its assessment too:
        :mod:`fringe3d.decode.device_temporal`; the other methods stay on the CPU).

    Examples
    --------
    >>> DecodeOptions(min_modulation=1.0).max_residual == math.pi / 2
    True
    """

    z_min: float | None = None
    z_max: float | None = None
    bit_depth: int | None = None
    min_modulation: float | None = None
    max_clip_bias: float | None = None
    fused: bool = True
    max_residual: float = 0.5 * math.pi
    max_code_residual: float = MAX_CODE_RESIDUAL
    ftp_window: str | None = None
    ftp_radius: float | None = None
    ftp_sign: int = 1
    erode: int | None = None
    min_size: int | None = None
    min_ratio: float | None = None
    max_shift: float | None = None
    cross_motion: bool | None = None
    white_thr: float | None = None
    black_thr: float | None = None
    edge_thr: float | None = None
    sub_stripe: bool | None = None
    edge_mask: bool = True
    edge_margin: float | None = None
    max_disagreement: float = 0.6
    gradient_ratio: float = 4.0
    modulation_ratio: float = 0.5
    rim: int = 1
    extra: Mapping[str, Any] = field(default_factory=dict)
    backend: str = "cpu"
    compensate: str | None = None
    response: Any = None

    def __post_init__(self) -> None:
        if self.compensate not in (None, "response", "harmonic", "disagreement"):
            raise ValueError(f"compensate must be 'response', 'harmonic' or 'disagreement', got {self.compensate!r}")
        if self.compensate == "response" and self.response is None:
            raise ValueError("compensate='response' needs the projector's response (DecodeOptions.response)")
