"""Specular reflection: an energy-normalised Blinn-Phong lobe toward the camera.

Per camera pixel the projector's light reaches the camera by two paths: the Lambertian one of
:mod:`fringe3d.sim.radiometry` (``albedo * cos(theta_i)``) and, on an object with a specular
weight ``k_s > 0``, a glossy lobe around the mirror direction. With ``l`` the unit direction to the
projector centre, ``v`` the unit direction to the camera, ``n`` the normal and ``h = (l + v) / |l + v|``
the half vector, the specular factor (in the units of the Lambertian ``albedo * cos(theta_i)``,
i.e. ``pi * f_r * cos(theta_i)``) is

``S = k_s * (p + 8) / 8 * (n . h)**p * cos(theta_i)``,     ``p = 2 / alpha**2 - 2``

the normalised Blinn-Phong BRDF (Akenine-Möller et al., *Real-Time Rendering*, Eq. 7.48) with
the roughness ``alpha`` of the GGX/Beckmann convention (Walter et al. 2007: Blinn-Phong with
exponent ``p`` approximates a Beckmann lobe of roughness ``alpha``). For fixed ``l`` and ``n`` the
lobe is largest where ``n . h = 1``, i.e. where ``v`` is the mirror direction of ``l``; a polished
part (``alpha`` ≈ 0.1, ``p`` ≈ 200) peaks ~25 ``k_s`` times brighter than white paper there,
which saturates any exposure that shows the rest of the part.

>>> import numpy as np
>>> n = np.array([[0.0, 0.0, 1.0]]); l = np.array([[0.6, 0.0, 0.8]])
>>> mirror = np.array([[-0.6, 0.0, 0.8]])
>>> float(lobe(n, l, mirror, 1.0, 0.2)[0]) > float(lobe(n, l, np.array([[0.0, 0.0, 1.0]]), 1.0, 0.2)[0])
True
"""
from __future__ import annotations

import math

import numpy as np


def exponent(roughness):
    """Blinn-Phong exponent ``p = 2 / alpha**2 - 2`` of roughness ``alpha`` in (0, 1] (float or array)."""
    return 2.0 / roughness**2 - 2.0


def check_gloss(specular: float, roughness: float) -> tuple[float, float]:
    """``(specular, roughness)`` as floats; ``ValueError`` naming the field when ``specular`` is not
    a finite number >= 0 or ``roughness`` not in [0.02, 1]."""
    s, r = float(specular), float(roughness)
    if not (math.isfinite(s) and s >= 0):
        raise ValueError(f"specular weight must be a finite number >= 0, got {specular!r}")
    if not (math.isfinite(r) and 0.02 <= r <= 1):
        raise ValueError(f"roughness must be in [0.02, 1] (0.02 polished .. 1 matte), got {roughness!r}")
    return s, r


def lobe(normal: np.ndarray, to_light: np.ndarray, to_camera: np.ndarray, specular, roughness) -> np.ndarray:
    """Specular factor ``S`` (N,) of the module's equation.

    Parameters
    ----------
    normal, to_light, to_camera : (N, 3) float
        Unit normal, unit direction to the projector centre and unit direction to the camera.
    specular, roughness : float or (N,) float
        Weight ``k_s`` and roughness ``alpha`` per row.

    Returns
    -------
    (N,) float64, 0 where the light or the camera is behind the surface.
    """
    n, lv, v = (np.asarray(a, float) for a in (normal, to_light, to_camera))
    h = lv + v
    h /= np.maximum(np.linalg.norm(h, axis=1, keepdims=True), 1e-12)
    cos_i = np.einsum("ij,ij->i", n, lv)
    cos_o = np.einsum("ij,ij->i", n, v)
    nh = np.clip(np.einsum("ij,ij->i", n, h), 0.0, 1.0)
    p = exponent(np.asarray(roughness, float))
    s = np.asarray(specular, float) * (p + 8.0) / 8.0 * nh**p * cos_i
    return np.where((cos_i > 0) & (cos_o > 0), s, 0.0)


def specular_factor(objects, object_id: np.ndarray, normal: np.ndarray, to_light: np.ndarray,
                    to_camera: np.ndarray, lit: np.ndarray) -> np.ndarray | None:
    """Per-pixel specular factor (N,) of a scene's glossy objects (attributes ``specular`` and
    ``roughness``, :meth:`~fringe3d.sim.scene_object.PosedObject.set_gloss`), 0 where unlit;
    None when no object is glossy (the renderer then skips the term)."""
    ks = np.array([float(getattr(ob, "specular", 0.0)) for ob in objects] + [0.0])
    if not np.any(ks > 0):
        return None
    alpha = np.array([float(getattr(ob, "roughness", 1.0)) for ob in objects] + [1.0])
    out = np.zeros(object_id.shape[0])
    rows = np.flatnonzero(lit & (ks[object_id] > 0))
    if rows.size:
        oid = object_id[rows]
        out[rows] = lobe(normal[rows], to_light[rows], to_camera[rows], ks[oid], alpha[oid])
    return out
