"""A freeform "sculpture": a smooth analytic relief ``z_b = f(x_b, y_b)`` over a rectangle.

``f`` is a sum of Gaussian bumps and sinusoidal ripples (closed-form value and gradient), so
the surface, its normal and its depth are exact. Rays are cast in the body frame by sampling
``g(t) = z(t) − f(x(t), y(t))`` across the slab ``min f ≤ z_b ≤ max f`` and refining the first
sign change by safeguarded Newton (numba) to ~1e-12 mm. Heights rise along body ``+z``; the
default pose (``R = diag(1, −1, −1)``) turns them towards a camera at the origin looking along +z.
"""
from __future__ import annotations

import numba
import numpy as np

from .motion import STATIC, RigidMotion
from .scene_object import PosedObject, check_albedo, check_rotation, check_vec3
from .textures import Blotches


@numba.njit(cache=True)
def _f(x, y, bumps, ripples):
    """Height and gradient of the relief at (x, y)."""
    z, zx, zy = 0.0, 0.0, 0.0
    for k in range(bumps.shape[0]):
        a, cx, cy, s = bumps[k, 0], bumps[k, 1], bumps[k, 2], bumps[k, 3]
        dx, dy = x - cx, y - cy
        e = a * np.exp(-(dx * dx + dy * dy) / (2 * s * s))
        z += e
        zx -= e * dx / (s * s)
        zy -= e * dy / (s * s)
    for k in range(ripples.shape[0]):
        b, kx, ky, ph = ripples[k, 0], ripples[k, 1], ripples[k, 2], ripples[k, 3]
        arg = kx * x + ky * y + ph
        z += b * np.sin(arg)
        c = b * np.cos(arg)
        zx += c * kx
        zy += c * ky
    return z, zx, zy


@numba.njit(cache=True)
def _heights(x, y, bumps, ripples):
    out = np.empty((x.shape[0], 3))
    for i in range(x.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = _f(x[i], y[i], bumps, ripples)
    return out


@numba.njit(cache=True)
def _cast(o, d, bumps, ripples, x0, x1, y0, y1, zlo, zhi, steps, spacing, slope, t_out, n_out, uv_out):
    shared = o.shape[0] == 1
    for i in range(d.shape[0]):
        j = 0 if shared else i
        t_out[i] = np.inf
        ox, oy, oz = o[j, 0], o[j, 1], o[j, 2]
        dx, dy, dz = d[i, 0], d[i, 1], d[i, 2]
        # clip the ray to the box [x0,x1]x[y0,y1]x[zlo,zhi]
        tn, tf = 1e-9, np.inf
        ok = True
        for lo, hi, oo, dd in ((x0, x1, ox, dx), (y0, y1, oy, dy), (zlo, zhi, oz, dz)):
            if dd == 0.0:
                if oo < lo or oo > hi:
                    ok = False
                continue
            a, b = (lo - oo) / dd, (hi - oo) / dd
            if a > b:
                a, b = b, a
            tn, tf = max(tn, a), min(tf, b)
        if not ok or tf <= tn:
            continue
        # sample so that consecutive samples are at most `spacing` mm apart laterally
        # march: each step is the larger of a Lipschitz-safe step |g| / max|g'| (cannot skip a
        # root) and the uniform sampling step (at most `spacing` mm laterally)
        dxy = np.sqrt(dx * dx + dy * dy)
        lip = abs(dz) + slope * dxy
        n_steps = min(max(4, int(dxy * (tf - tn) / spacing) + 1), steps)
        min_dt = (tf - tn) / n_steps
        ta = tn
        fz, _, _ = _f(ox + ta * dx, oy + ta * dy, bumps, ripples)
        ga = oz + ta * dz - fz
        found = False
        tb = ta
        for _ in range(4 * steps):
            if ga == 0.0:
                tb = ta
                found = True
                break
            if ta >= tf:
                break
            tb = min(ta + max(abs(ga) / lip, min_dt), tf)
            fz, _, _ = _f(ox + tb * dx, oy + tb * dy, bumps, ripples)
            gb = oz + tb * dz - fz
            if (ga < 0) != (gb < 0) or gb == 0.0:
                found = True
                break
            ta, ga = tb, gb
        if not found:
            continue
        # safeguarded Newton inside the bracket [lo_t, hi_t]
        lo_t, hi_t, glo = ta, tb, ga
        t = 0.5 * (lo_t + hi_t)
        for _ in range(60):
            fz, fx, fy = _f(ox + t * dx, oy + t * dy, bumps, ripples)
            g = oz + t * dz - fz
            if g == 0.0:
                lo_t = hi_t = t
                break
            if (g < 0) == (glo < 0):
                lo_t, glo = t, g
            else:
                hi_t = t
            dg = dz - fx * dx - fy * dy
            tn_ = t - g / dg if dg != 0.0 else 0.5 * (lo_t + hi_t)
            if not (lo_t < tn_ < hi_t):
                tn_ = 0.5 * (lo_t + hi_t)
            if abs(tn_ - t) <= 1e-14 * abs(t) or hi_t - lo_t <= 1e-14 * hi_t:
                t = tn_
                break
            t = tn_
        x, y = ox + t * dx, oy + t * dy
        fz, fx, fy = _f(x, y, bumps, ripples)
        t_out[i] = t
        n_out[i, 0] = -fx
        n_out[i, 1] = -fy
        n_out[i, 2] = 1.0
        uv_out[i, 0] = x
        uv_out[i, 1] = y


def _table(rows, name, width=4):
    a = np.asarray(rows if rows is not None and len(rows) else np.zeros((0, width)), float).reshape(-1, width)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite numbers")
    return a


class HeightField(PosedObject):
    """Analytic relief ``z_b = Σ A exp(−r²/2σ²) + Σ B sin(k·x + φ)`` over a rectangle.

    Parameters
    ----------
    size : (width, height) mm of the rectangle centred on the body origin.
    bumps : (K, 4) rows ``(A mm, x mm, y mm, σ mm)``.
    ripples : (J, 4) rows ``(B mm, kx rad/mm, ky rad/mm, φ rad)``.
    center, R : pose of the body frame (default R faces the relief towards a camera at the
        origin looking along +z).
    steps : most samples along each ray inside the relief's slab before refinement (samples are
        at most a quarter of the narrowest feature apart laterally).
    """

    def __init__(self, size=(120.0, 100.0), bumps=None, ripples=None, center=(0.0, 0.0, 450.0), R=None,
                 albedo=0.85, texture=None, steps=48, motion: RigidMotion = STATIC):
        self.size = np.asarray(size, float).ravel()
        if self.size.shape != (2,) or np.any(self.size <= 0):
            raise ValueError(f"height-field size must be (width, height) > 0 mm, got {size}")
        self.bumps = _table(bumps, "bumps")
        self.ripples = _table(ripples, "ripples")
        if np.any(self.bumps[:, 3] <= 0):
            raise ValueError("bump widths sigma must be > 0 mm")
        self.center = check_vec3(center, "center")
        self.R = np.diag([1.0, -1.0, -1.0]) if R is None else check_rotation(R)
        self.albedo = check_albedo(albedo)
        self.texture = texture
        self.motion = motion
        self.steps = int(steps)
        if self.steps < 4:
            raise ValueError(f"steps must be >= 4, got {steps}")
        widths = list(self.bumps[:, 3]) + [np.pi / max(np.hypot(kx, ky), 1e-9) for _, kx, ky, _ in self.ripples]
        self.spacing = 0.25 * min(widths) if widths else 1.0  # lateral sampling (mm) before refinement
        self.z_range, self.slope = self._slab()

    def _slab(self):
        """Enclosure ``((lo, hi), slope)`` of f over the rectangle: the extremes on a grid of half
        the sampling spacing, padded by max|∇f| × grid diagonal, and a slope bound
        (1.25 × the grid's max|∇f|) for Lipschitz-safe marching."""
        w, h = 0.5 * self.size
        step = 0.5 * self.spacing
        xs = np.linspace(-w, w, max(2, int(2 * w / step) + 2))
        ys = np.linspace(-h, h, max(2, int(2 * h / step) + 2))
        gx, gy = np.meshgrid(xs, ys)
        v = _heights(gx.ravel(), gy.ravel(), self.bumps, self.ripples)
        pad = np.hypot(v[:, 1], v[:, 2]).max() * np.hypot(xs[1] - xs[0], ys[1] - ys[0]) + 1e-6
        slope = 1.25 * float(np.hypot(v[:, 1], v[:, 2]).max()) + 1e-9
        return (float(v[:, 0].min() - pad), float(v[:, 0].max() + pad)), slope

    def height(self, xy) -> np.ndarray:
        """``f`` at body points ``xy`` (M, 2): returns (M, 3) columns ``(f, f_x, f_y)``."""
        xy = np.asarray(xy, float).reshape(-1, 2)
        return _heights(xy[:, 0].copy(), xy[:, 1].copy(), self.bumps, self.ripples)

    def surface_points(self, xy, time: float = 0.0) -> np.ndarray:
        """World points (M, 3) of the relief above body ``xy`` (M, 2)."""
        xy = np.asarray(xy, float).reshape(-1, 2)
        return self.to_world(np.column_stack([xy, self.height(xy)[:, 0]]), time)

    def to_dict(self) -> dict:
        return {"type": "heightfield", "size": self.size.tolist(), "bumps": self.bumps.tolist(),
                "ripples": self.ripples.tolist(), "center": self.center.tolist(), "R": self.R.tolist(),
                "steps": self.steps, **self._style_dict()}

    def bounding_sphere_body(self):
        zc = 0.5 * sum(self.z_range)
        half = np.r_[0.5 * self.size, 0.5 * (self.z_range[1] - self.z_range[0])]
        return np.array([0.0, 0.0, zc]), float(np.linalg.norm(half))

    def intersect_body(self, o, d):
        t = np.empty(len(d))
        n = np.zeros_like(d)
        uv = np.full((len(d), 2), np.nan)
        w, h = 0.5 * self.size
        _cast(o, d, self.bumps, self.ripples, -w, w, -h, h, self.z_range[0], self.z_range[1],
              self.steps, self.spacing, self.slope, t, n, uv)
        return t, n, uv

    def to_mesh(self, step: float = 1.0):
        """Tessellate the relief (body frame, mm) into a ``trimesh.Trimesh`` with vertices on
        the exact surface (grid ``step`` mm)."""
        # heavy (about 1 s to import): only tessellation needs it
        import trimesh

        w, h = 0.5 * self.size
        xs = np.linspace(-w, w, int(round(2 * w / step)) + 1)
        ys = np.linspace(-h, h, int(round(2 * h / step)) + 1)
        gx, gy = np.meshgrid(xs, ys)
        xy = np.column_stack([gx.ravel(), gy.ravel()])
        V = np.column_stack([xy, self.height(xy)[:, 0]])
        idx = np.arange(len(xy)).reshape(len(ys), len(xs))
        q = np.stack([idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]], -1).reshape(-1, 4)
        F = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
        return trimesh.Trimesh(V, F, process=False)

    def describe(self) -> str:
        return f"HeightField {self.size[0]:g}x{self.size[1]:g} mm, {len(self.bumps)} bumps, {len(self.ripples)} ripples"


def sculpture(center=(0.0, 0.0, 450.0), size=(120.0, 100.0), relief=25.0, seed: int = 0, R=None,
              texture="blotches", albedo=0.85, motion: RigidMotion = STATIC) -> HeightField:
    """A seeded freeform relief (a "head" bump, cheeks, brow ridge, ripples) ``relief`` mm deep,
    textured by default with a smooth printed pattern (material coordinates = body x, y mm).

    Parameters
    ----------
    center : (3,) array_like
        Position of the body origin (mm, world frame).
    size : (2,) array_like
        ``(width, height)`` of the relief's rectangle (mm).
    relief : float
        Height of the main bump (mm); the other bumps and the ripples scale with it.
    seed : int
        Seed of the random bumps, ripples and texture.
    R : (3, 3) array_like, optional
        Rotation of the body frame (default faces the relief towards a camera at the origin
        looking along +z).
    texture : str or texture
        ``"blotches"``: a seeded :class:`Blotches` print; anything else is passed to the height
        field as its texture.
    albedo : float
        Surface albedo.
    motion : RigidMotion
        Motion of the body (default static).

    Returns
    -------
    HeightField
        The relief.
    """
    rng = np.random.default_rng(seed)
    w, h = 0.5 * np.asarray(size, float)
    bumps = [(relief, 0.0, 0.0, 0.35 * min(w, h))]
    for _ in range(6):
        bumps.append((rng.uniform(-0.25, 0.35) * relief, rng.uniform(-0.6, 0.6) * w,
                      rng.uniform(-0.6, 0.6) * h, rng.uniform(0.08, 0.2) * min(w, h)))
    ripples = [(0.03 * relief, 2 * np.pi / rng.uniform(15, 30), 2 * np.pi / rng.uniform(20, 40), rng.uniform(0, 6.3))]
    tex = Blotches(scale=0.15 * min(w, h) * 2, contrast=0.35, seed=seed) if texture == "blotches" else texture
    return HeightField(size=size, bumps=bumps, ripples=ripples, center=center, R=R, albedo=albedo,
                       texture=tex, motion=motion)
