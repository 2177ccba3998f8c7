"""Projector sampling: the pattern value each lit surface point receives, and the caches.

Ideal mode evaluates phase-shifted sinusoids analytically at the exact projector coordinate
(``sinusoid_value``); otherwise the projector image (``render_frame``) blurred by the defocus OTF
(Eq. 2.22-2.26) is sampled bilinearly, with the blur optionally growing with the distance from
the focal plane (interpolated between a few blur levels). Blurred images are kept in a small
least-recently-used cache across render calls (:data:`IMAGE_CACHE`).

>>> import numpy as np
>>> sample(np.array([[0.0, 1.0], [2.0, 3.0]]), np.array([0.5]), np.array([0.5])).tolist()
[1.5]
"""
from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Iterator
from contextlib import contextmanager

import numba
import numpy as np

from fringe3d.optics.defocus import blur_pattern, defocus_size_at
from fringe3d.patterns.manifest import FrameSpec, PatternSet
from fringe3d.patterns.render import render_frame, sinusoid_value

from .geometry import Geometry
from .settings import RenderSettings


@numba.njit(cache=True, parallel=False, nogil=True)
def bilinear(image, u, v, out):
    """Bilinear sample of ``image`` (H, W) at float coordinates (u column, v row), edge-clamped.

    Writes ``out[i]``; NaN coordinates give 0. Bit-identical to
    ``fringe3d.phase.sampling.sample_bilinear(image, np.stack([u, v], -1), outside="clamp",
    combine="rows")``, kept as a numba loop because the renderer samples every lit pixel of
    every frame: the NumPy version (about 15 full-size temporaries) took 0.34 s against
    0.05 s here for 10^6 samples of a 912 x 1140 image.
    """
    H, W = image.shape
    for i in range(u.shape[0]):
        x = u[i]
        y = v[i]
        if not (x == x and y == y):  # NaN
            out[i] = 0.0
            continue
        x = min(max(x, 0.0), W - 1.0)
        y = min(max(y, 0.0), H - 1.0)
        x0 = min(int(x), W - 2) if W > 1 else 0
        y0 = min(int(y), H - 2) if H > 1 else 0
        fx = x - x0
        fy = y - y0
        x1 = min(x0 + 1, W - 1)
        y1 = min(y0 + 1, H - 1)
        out[i] = ((1 - fy) * ((1 - fx) * image[y0, x0] + fx * image[y0, x1])
                  + fy * ((1 - fx) * image[y1, x0] + fx * image[y1, x1]))
    return out


def sample(image: np.ndarray, up: np.ndarray, vp: np.ndarray) -> np.ndarray:
    """Bilinear sample of a projector image at projector coordinates (pixels)."""
    out = np.empty(up.shape[0])
    return bilinear(np.ascontiguousarray(image, dtype=np.float64), np.ascontiguousarray(up, float),
                    np.ascontiguousarray(vp, float), out)


#: Blurred projector images shared by every render call: key -> read-only (H, W) float64.
IMAGE_CACHE: OrderedDict[tuple, np.ndarray] = OrderedDict()
#: Most projector images kept in :data:`IMAGE_CACHE` (about 8 MB each at 912 x 1140).
IMAGE_CACHE_SIZE = 12
#: Guards :data:`IMAGE_CACHE` (a render shades its frames on several threads).
_CACHE_LOCK = threading.Lock()
_held: list[int] = []


def projector_image(spec: FrameSpec, width: int, height: int, defocus: str, size: float) -> np.ndarray:
    """The projector image of frame ``spec`` (``render_frame``) blurred by the defocus OTF of
    ``size`` (Eq. 2.22-2.26), (height, width) float64, read-only.

    Kept in a small least-recently-used cache across render calls (a pattern set rendered
    again, e.g. a repeated capture or a benchmark, does not re-render and re-blur it); inside
    :func:`images_held` it keeps at least the number of images asked for."""
    key = (spec, int(width), int(height), str(defocus), round(float(size), 6))
    with _CACHE_LOCK:
        img = IMAGE_CACHE.get(key)
        if img is not None:
            IMAGE_CACHE.move_to_end(key)
            return img
    img = render_frame(spec, width, height).astype(np.float64)
    if defocus != "none" and size > 0:
        img = blur_pattern(img, defocus, size)
    img.setflags(write=False)
    with _CACHE_LOCK:
        IMAGE_CACHE[key] = img
        _trim()
    return img


def _trim() -> None:
    while len(IMAGE_CACHE) > max([IMAGE_CACHE_SIZE, *_held]):
        IMAGE_CACHE.popitem(last=False)


@contextmanager
def images_held(count: int) -> Iterator[None]:
    """Inside the block :data:`IMAGE_CACHE` keeps at least ``count`` projector images, for renders
    that cycle through more images than it usually holds (a calibration session projects the same
    set at every board pose: each image is rendered and blurred once, not once per pose); back to
    :data:`IMAGE_CACHE_SIZE` afterwards."""
    with _CACHE_LOCK:
        _held.append(int(count))
    try:
        yield
    finally:
        with _CACHE_LOCK:
            _held.remove(int(count))
            _trim()


class PatternSampler:
    """Pattern values at projector coordinates for one pattern set and render settings.

    Keeps the images it used (up to 64) and takes new ones from :func:`projector_image`
    (cached across calls).
    """

    def __init__(self, patterns: PatternSet, settings: RenderSettings):
        self.patterns = patterns
        self.settings = settings
        self._cache: dict[tuple[FrameSpec, float], np.ndarray] = {}

    def _image(self, spec: FrameSpec, size: float) -> np.ndarray:
        key = (spec, round(float(size), 6))
        img = self._cache.get(key)
        if img is None:
            img = projector_image(spec, self.patterns.width, self.patterns.height, self.settings.defocus, size)
            with _CACHE_LOCK:
                if len(self._cache) > 64:
                    self._cache.clear()
                self._cache[key] = img
        return img

    def values(self, spec: FrameSpec, geo: Geometry) -> np.ndarray:
        """Pattern value in [0, 1] (before gamma) at every lit pixel of ``geo``; 0 elsewhere."""
        s = self.settings
        out = np.zeros(geo.lit.shape[0])
        idx = np.flatnonzero(geo.lit)
        if not idx.size:
            return out
        up, vp = geo.up[idx], geo.vp[idx]
        if s.ideal:
            out[idx] = sinusoid_value(spec, up, vp, self.patterns.width, self.patterns.height)
            return out
        if s.defocus == "none" or s.focus_distance is None or s.defocus_growth == 0:
            out[idx] = sample(self._image(spec, s.defocus_size), up, vp)
            return out
        sizes = defocus_size_at(geo.proj_depth[idx], s.defocus_size, s.focus_distance, s.defocus_growth)
        lo, hi = float(sizes.min()), float(sizes.max())
        n = int(min(8, max(2, np.ceil((hi - lo) / 0.25) + 1)))
        levels = np.linspace(lo, hi, n) if hi > lo else np.array([lo, lo])
        samples = np.stack([sample(self._image(spec, z), up, vp) for z in levels])
        pos = np.interp(sizes, levels, np.arange(len(levels)))
        i0 = np.minimum(pos.astype(int), len(levels) - 2)
        f = pos - i0
        r = np.arange(idx.size)
        out[idx] = (1 - f) * samples[i0, r] + f * samples[i0 + 1, r]
        return out
