"""The decoder's outputs: :class:`Unwrapped` (one method, one direction) and :class:`Decoded`
(absolute phase, wrapped phase, modulation and mask per direction of one pattern cycle)."""
from __future__ import annotations

import zipfile
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from fringe3d.decode.edges import INVALID, ORDER
from fringe3d.io.decoded_files import (MAP_UNITS, NPZ_NAME, SUMMARY_NAME, SUMMARY_UNITS,  # noqa: F401
                                      read_decoded_npz, write_decoded_files)
from fringe3d.patterns.conventions import phase_to_w
from fringe3d.phase.quality import DARK_FRACTION, DARK_PERCENTILE

from fringe3d.utils.output_folder import check_complete

_PER_DIRECTION = ("phase", "wrapped", "modulation", "mask")
#: Per-direction maps that older decode outputs lack (read when present).
_OPTIONAL = ("quality", "phase_sigma")


def order_share(quality: np.ndarray) -> float:
    """Share of the method's valid pixels (no ``INVALID`` bit) that carry the ``ORDER`` bit."""
    method_valid = np.count_nonzero((quality & INVALID) == 0)
    return float(np.count_nonzero(quality & ORDER) / method_valid) if method_valid else 0.0


@dataclass(frozen=True, eq=False)
class Unwrapped:
    """What a decoding method returns for one fringe direction.

    Attributes
    ----------
    phase : (H, W) float
        Absolute phase ``Phi`` (rad) of the method's period (by default the plan's narrowest).
    mask : (H, W) bool
        Valid pixels.
    wrapped, modulation, average : (H, W) float, optional
        Override the decoder's wrapped phase, modulation and average of the direction (e.g. an
        FTP-based method's own analysis); None: the narrowest group's.
    texture : (H, W) float, optional
        Texture computed on the way (the fused kernel's average + modulation, frames' units; the
        decoder turns it into a fraction of full scale).
    period : float, optional
        Fringe period (projector pixels) of ``phase`` when it is not the plan's narrowest.
    phase_is_masked : bool
        ``phase`` is float32 and already NaN exactly where ``mask`` is False (the decoder then
        uses it as is).
    labels : (H, W) int, optional
        Object labels of object-wise methods (spatial, hybrid).
    object_orders : dict label -> int, optional
        Fringe-order shift ``k_s`` per object (hybrid, Eq. 5.14).
    order_inconsistent : (H, W) bool, optional
        Pixels of ``mask`` whose two fringe-order estimates disagree (code vs phase, coarse vs
        fine frequency) beyond the method's tolerance; the decoder masks them with the quality
        bit ``ORDER`` (:mod:`fringe3d.decode.edges`).
    """

    phase: np.ndarray
    mask: np.ndarray
    wrapped: np.ndarray | None = None
    modulation: np.ndarray | None = None
    average: np.ndarray | None = None
    texture: np.ndarray | None = None
    period: float | None = None
    phase_is_masked: bool = False
    labels: np.ndarray | None = None
    object_orders: dict[int, int] | None = None
    order_inconsistent: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class DirectionMaps:
    """One fringe direction of a :class:`Decoded`: its maps and plan facts, typed.

    Attributes
    ----------
    direction : str
        The direction's key (e.g. ``"v"``).
    phase : (H, W) float32
        Absolute phase (rad), NaN where invalid.
    wrapped : (H, W) float32
        Wrapped phase (rad) in (-pi, pi].
    modulation : (H, W) float32
        Fringe modulation (frames' units).
    mask : (H, W) bool
        Valid pixels.
    period : float
        Fringe period of ``phase`` (projector px).
    angle : float
        Fringe angle (rad).
    method : str or None
        The unwrapping method.
    quality : (H, W) uint8 or None
        Bit flags of why a pixel is masked (:mod:`fringe3d.decode.edges`); None in older outputs.
    phase_sigma : (H, W) float32 or None
        Predicted phase standard deviation (rad); None in older outputs.
    """

    direction: str
    phase: np.ndarray
    wrapped: np.ndarray
    modulation: np.ndarray
    mask: np.ndarray
    period: float
    angle: float
    method: str | None = None
    quality: np.ndarray | None = None
    phase_sigma: np.ndarray | None = None

    def projector_coordinate(self) -> np.ndarray:
        """(H, W) float32 projector fringe coordinate ``w = Phi T / 2 pi`` (px), NaN invalid.

        Returns
        -------
        (H, W) float32
            The coordinate, as :meth:`Decoded.projector_coordinate`.
        """
        return phase_to_w(self.phase, float(self.period)).astype(np.float32)


@dataclass
class Decoded:
    """Decoded phase maps of one pattern cycle.

    Per fringe direction ``d`` (dict keys, e.g. ``"v"``, ``"h"``), each (H, W):
    ``phase[d]`` absolute phase float32 rad (NaN where invalid; ``u_p = phase * period / 2pi``
    for direction ``"v"``), ``wrapped[d]`` wrapped phase float32 in (-pi, pi],
    ``modulation[d]`` float32 (frames' units), ``mask[d]`` bool; ``period[d]`` (px),
    ``angle[d]`` (rad), ``method[d]`` (unwrapping method), ``quality[d]`` uint8 (0 = good;
    one bit per reason a pixel is masked: 1 invalid, 2 projector-edge band, 4 multi-frequency
    disagreement, 8 phase-gradient jump, 16 modulation drop, 32 rim, 64 fringe-order estimates
    disagree; :mod:`fringe3d.decode.edges`),
    ``phase_sigma[d]`` float32 predicted phase standard deviation (rad, ``sqrt(2/N) sigma / B``;
    NaN where unknown). Plus ``average`` (H, W) float32 (frames' units) and ``texture`` (H, W)
    float32, a fraction of full scale in [0, 1] (:mod:`fringe3d.decode.texture`), and ``info`` (frame
    checks, warnings, per-direction ``quality`` info: blur, margin, noise model, bit counts).
    """

    phase: dict[str, np.ndarray] = field(default_factory=dict)
    wrapped: dict[str, np.ndarray] = field(default_factory=dict)
    modulation: dict[str, np.ndarray] = field(default_factory=dict)
    mask: dict[str, np.ndarray] = field(default_factory=dict)
    period: dict[str, float] = field(default_factory=dict)
    angle: dict[str, float] = field(default_factory=dict)
    method: dict[str, str] = field(default_factory=dict)
    quality: dict[str, np.ndarray] = field(default_factory=dict)
    phase_sigma: dict[str, np.ndarray] = field(default_factory=dict)
    average: np.ndarray | None = None
    texture: np.ndarray | None = None
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def directions(self) -> list[str]:
        """The fringe directions, in decoding order."""
        return list(self.phase)

    def __getitem__(self, direction: str) -> DirectionMaps:
        """One direction's maps, typed: ``decoded["v"].phase`` is ``decoded.phase["v"]``."""
        if direction not in self.phase:
            raise KeyError(f"no fringe direction {direction!r}; this result has {self.directions}")
        return DirectionMaps(direction=direction, phase=self.phase[direction], wrapped=self.wrapped[direction],
                             modulation=self.modulation[direction], mask=self.mask[direction],
                             period=float(self.period[direction]), angle=float(self.angle[direction]),
                             method=self.method.get(direction), quality=self.quality.get(direction),
                             phase_sigma=self.phase_sigma.get(direction))

    def __iter__(self) -> Iterator[str]:
        """The directions, as a mapping's keys (``for d in decoded``)."""
        return iter(self.directions)

    def by_direction(self) -> dict[str, DirectionMaps]:
        """Every direction's :class:`DirectionMaps`, in decoding order.

        Returns
        -------
        dict of str to DirectionMaps
            ``{direction: decoded[direction]}``.
        """
        return {d: self[d] for d in self.directions}

    def projector_coordinate(self, direction: str) -> np.ndarray:
        """(H, W) float32 projector fringe coordinate ``w = Phi T / 2 pi`` (px), NaN invalid."""
        # float32 phase times a Python float: the scale is rounded to float32, as the product
        return phase_to_w(self.phase[direction], float(self.period[direction])).astype(np.float32)

    def summary(self) -> dict:
        """Small JSON-friendly description: per direction period, angle, method, valid fraction and
        ``order_inconsistent``, the share of the method's valid pixels masked because their two
        fringe-order estimates disagree (quality bit ``ORDER``; None without a quality map)."""
        out: dict[str, Any] = {"directions": {}}
        for d in self.directions:
            m = self.mask[d]
            out["directions"][d] = {
                "method": self.method.get(d), "period": float(self.period[d]), "angle": float(self.angle[d]),
                "valid_fraction": float(m.mean()) if m.size else 0.0,
                "phase_min": float(np.nanmin(self.phase[d])) if m.any() else None,
                "phase_max": float(np.nanmax(self.phase[d])) if m.any() else None,
                "median_modulation": float(np.median(self.modulation[d][m])) if m.any() else None,
                "order_inconsistent": order_share(self.quality[d]) if d in self.quality else None,
            }
        out["shape"] = list(self.average.shape) if self.average is not None else None
        out["info"] = self.info
        return out

    def empty_reason(self) -> str | None:
        """Why no pixel is valid in any direction (None when some are): which check removed them."""
        if any(self.mask[d].any() for d in self.directions):
            return None
        thr = self.info.get("min_modulation")
        parts = []
        for d in self.directions:
            mod = self.modulation[d]
            finite = mod[np.isfinite(mod)]
            top = float(np.percentile(finite, 99)) if finite.size else float("nan")
            parts.append(f"direction {d}: modulation at most ~{top:.3g} (99th percentile)")
        why = "; ".join(parts)
        if thr is not None:
            why += f"; the modulation threshold is {thr:.3g} (lower it with `min_modulation`, or check the exposure"
            why += " and that the projector lit the scene)"
        checks = self.info.get("frame_checks") or {}
        if checks.get("frames") and len(checks.get("dark", ())) == checks["frames"]:
            why = (f"the frames are nearly black (in every frame at least {DARK_PERCENTILE:g} % of the pixels are "
                   f"below {DARK_FRACTION:.0%} of full scale {checks['full_scale']:g}; check the exposure, the "
                   f"aperture and that the projector lit the scene); {why}")
        return f"no valid pixel in any direction: {why}"

    def save(self, folder: str | os.PathLike) -> Path:
        """Write ``decoded.npz``, ``decoded.json`` and one TIFF per map, each atomically: 32-bit
        float ``phase_<d>.tif`` and ``phase_sigma_<d>.tif`` (NaN outside the mask),
        ``wrapped_<d>.tif``, ``modulation_<d>.tif``, ``average.tif``, ``texture.tif``; uint8
        ``mask_<d>.tif`` (0/1) and ``quality_<d>.tif`` (bits). Returns the folder."""

        arrays = {}
        for d in self.directions:
            for name in _PER_DIRECTION:
                arrays[f"{name}_{d}"] = getattr(self, name)[d]
            for name in _OPTIONAL:
                if d in getattr(self, name):
                    arrays[f"{name}_{d}"] = getattr(self, name)[d]
        for name in ("average", "texture"):
            if getattr(self, name) is not None:
                arrays[name] = getattr(self, name)
        meta = {"period": self.period, "angle": self.angle, "method": self.method,
                "directions": self.directions}
        return write_decoded_files(Path(folder), arrays, meta, self.summary())

    @classmethod
    def load(cls, folder: str | os.PathLike) -> "Decoded":
        """Read what :meth:`save` wrote (``decoded.npz`` in ``folder``, or the file itself)."""
        path = Path(folder)
        if path.is_dir():
            path = path / NPZ_NAME
        if not path.exists():
            raise FileNotFoundError(f"no decoded phase file at {path}; expected the output of `fringe3d decode`")
        if path.parent.is_dir():
            check_complete(path.parent, "decode output")
        try:
            return cls._read(path)
        except (KeyError, ValueError, TypeError, OSError, zipfile.BadZipFile, RecursionError) as e:
            raise ValueError(f"decoded phase file {path} is damaged or not written by `fringe3d decode` "
                             f"({type(e).__name__}: {e}); decode the capture again") from None

    @classmethod
    def _read(cls, path: Path) -> "Decoded":
        meta, z = read_decoded_npz(path)
        out = cls(period={k: float(v) for k, v in meta["period"].items()},
                  angle={k: float(v) for k, v in meta["angle"].items()}, method=dict(meta["method"]))
        for d in meta["directions"]:
            for name in _PER_DIRECTION:
                getattr(out, name)[d] = z[f"{name}_{d}"]
            for name in _OPTIONAL:
                if f"{name}_{d}" in z:
                    getattr(out, name)[d] = z[f"{name}_{d}"]
        out.average = z.get("average")
        out.texture = z.get("texture")
        return out
