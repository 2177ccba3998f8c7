"""Triangle meshes (OBJ / PLY / STL / ...) ray-cast with Embree through trimesh + embreex.

Embree (the ``embreex`` binding trimesh's ``ray_pyembree`` uses) finds the first triangle along
each ray (single precision); the ray parameter, hit
point and normal are then recomputed in double precision from that triangle's plane, so hits
lie on the mesh to ~1e-12 mm. Meshes are in their own body frame (mm) and posed like every
scene object (``R``, ``center``, optional :class:`RigidMotion`).
"""
from __future__ import annotations

from pathlib import Path

import numba
import numpy as np

from .hits import Hit, as_rays
from .motion import STATIC, RigidMotion
from .scene_object import (
    CullingVolume,
    PosedObject,
    check_albedo,
    check_rotation,
    check_vec3,
    rigid_to_body,
)


def load_mesh(path):
    """Read a triangle mesh with trimesh (any format it knows: OBJ, PLY, STL, OFF, GLB...)."""
    # heavy (about 1 s to import): loaded only when a mesh file is read
    import trimesh

    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"no mesh file at {path}")
    try:
        mesh = trimesh.load(path, force="mesh", process=False)
    except Exception as e:  # trimesh raises many types for unreadable files
        raise ValueError(f"could not read mesh {path}: {e}") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise ValueError(f"mesh {path} holds no triangles")
    return mesh


class _EmbreeFirstHit:
    """First-triangle queries on an Embree scene (embreex, as trimesh.ray.ray_pyembree builds it).

    Vertices are shifted to the mesh's bounding-box minimum before the single-precision
    conversion (as trimesh does) to keep Embree's float32 precise."""

    def __init__(self, mesh):
        # optional: embreex (x86-64 only); an ImportError selects the trimesh fallback
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        v = np.asarray(mesh.vertices, dtype=np.float64)
        self.origin = v.min(axis=0)
        self.scene = rtcore_scene.EmbreeScene()
        TriangleMesh(scene=self.scene, vertices=(v - self.origin).astype(np.float32),
                     indices=np.asarray(mesh.faces, dtype=np.int32))

    def first(self, o, d):
        """Triangle index (N,) int (-1 = miss) for body-frame rays ``o`` (1 or N, 3), ``d`` (N, 3)."""
        o32 = np.empty(d.shape, np.float32)
        o32[:] = o - self.origin
        return self.scene.run(o32, d.astype(np.float32))


class _TrimeshFirstHit:
    """Fallback without embreex: trimesh's pure-NumPy ray/triangle test (slow but exact)."""

    def __init__(self, mesh):
        # heavy (trimesh, about 1 s to import): only meshes without embreex need it
        from trimesh.ray.ray_triangle import RayMeshIntersector
        self.rays = RayMeshIntersector(mesh)

    def first(self, o, d):
        return self.rays.intersects_first(np.broadcast_to(o, d.shape), d)


def _intersector(mesh):
    try:
        return _EmbreeFirstHit(mesh)
    except ImportError:
        return _TrimeshFirstHit(mesh)


class Mesh(PosedObject):
    """A triangle mesh scene object.

    Parameters
    ----------
    mesh : trimesh.Trimesh or path
        The mesh (body-frame vertices in mm), or a file for :func:`load_mesh`.
    center : (3,) world position of the body origin (mm).
    R : body → world rotation ((3, 3) or rotation vector).
    scale : float, multiplies body vertices (e.g. 1000 for a mesh in metres).
    smooth : bool, interpolate vertex normals (default: exact face normals).
    albedo, texture : base albedo and texture; material coordinates are the mesh's UV (× 1)
        when it has them, else the body-frame ``(x, y)`` of the hit (mm).
    """

    def __init__(self, mesh, center=(0.0, 0.0, 0.0), R=None, scale=1.0, smooth=False, albedo=1.0,
                 texture=None, motion: RigidMotion = STATIC):
        if isinstance(mesh, (str, Path)):
            self.source: str | None = str(Path(mesh).resolve())
            mesh = load_mesh(mesh)
        else:
            self.source = None
        if not hasattr(mesh, "faces") or len(mesh.faces) == 0:
            raise ValueError("Mesh needs a trimesh.Trimesh with at least one triangle")
        scale = float(scale)
        if not scale > 0:
            raise ValueError(f"mesh scale must be > 0, got {scale}")
        self.scale = scale
        if scale != 1.0:
            mesh = mesh.copy()
            mesh.apply_scale(scale)
        self.mesh = mesh
        self.center = check_vec3(center, "center")
        self.R = np.eye(3) if R is None else check_rotation(R)
        self.smooth = bool(smooth)
        self.albedo = check_albedo(albedo)
        self.texture = texture
        self.motion = motion
        self._tri = np.ascontiguousarray(mesh.triangles, dtype=np.float64)  # (F, 3, 3)
        self._fn = np.ascontiguousarray(mesh.face_normals, dtype=np.float64)
        self._vn = np.ascontiguousarray(mesh.vertex_normals, dtype=np.float64) if smooth else None
        uv = getattr(getattr(mesh, "visual", None), "uv", None)
        self._uv = None if uv is None or len(uv) != len(mesh.vertices) else np.ascontiguousarray(uv, float)
        self._v0 = np.ascontiguousarray(self._tri[:, 0])
        self._faces = np.ascontiguousarray(mesh.faces, dtype=np.int64)
        self._rays = _intersector(mesh)

    @property
    def n_faces(self) -> int:
        return len(self.mesh.faces)

    def to_dict(self) -> dict:
        if self.source is None:
            raise ValueError("a mesh built in memory cannot be saved to a scene file; export it "
                             "(mesh.mesh.export('file.ply')) and load it with Mesh('file.ply')")
        return {"type": "mesh", "path": self.source, "center": self.center.tolist(), "R": self.R.tolist(),
                "scale": self.scale, "smooth": self.smooth, **self._style_dict()}

    def culling_volume(self, time: float = 0.0) -> CullingVolume:
        """The oriented body-frame bounding box (``mesh.bounds``, padded by 1e-6 of its extent)."""
        R, c = self.pose(time)
        lo, hi = np.asarray(self.mesh.bounds, float)
        pad = 1e-6 * (1.0 + np.abs(hi - lo).max())
        return CullingVolume(np.asarray(c, float), -1.0, np.asarray(R, float), lo - pad, hi + pad)

    def bounding_sphere_body(self) -> tuple[np.ndarray, float]:
        lo, hi = self.mesh.bounds
        c = 0.5 * (lo + hi)
        return c, float(np.linalg.norm(self.mesh.vertices - c, axis=1).max())

    def intersect(self, origins: np.ndarray, dirs: np.ndarray, time: float = 0.0) -> Hit:
        o, d = as_rays(origins, dirs)
        R, c = self.pose(time)
        ob, db = rigid_to_body(o, R, c), rigid_to_body(d, R)
        t, normal, uv = self._refine(ob, db, self._rays.first(ob, db), R)
        return self._finish(t, normal, uv, d, reuse=True)

    def hit_distance(self, origins: np.ndarray, dirs: np.ndarray, time: float = 0.0) -> np.ndarray:
        """Ray parameter (N,) of the first hit, ``inf`` where :meth:`intersect` reports a miss
        (same double-precision ``t``; no normals, material coordinates or albedo)."""
        o, d = as_rays(origins, dirs)
        R, c = self.pose(time)
        ob, db = rigid_to_body(o, R, c), rigid_to_body(d, R)
        t = np.empty(len(d))
        _plane_t_kernel(ob, db, np.ascontiguousarray(self._rays.first(ob, db), dtype=np.int64),
                        self._v0, self._fn, t)
        return t

    def _refine(self, ob, db, tri, R):
        """Double-precision ``t`` (N,), world normal (N, 3) and material uv (N, 2) of the
        Embree triangles ``tri`` (N,) (-1 = miss: inf / NaN / NaN), in one numba pass."""
        n = len(db)
        t, normal, uv = np.empty(n), np.empty((n, 3)), np.empty((n, 2))
        none3, none2 = np.empty((0, 3)), np.empty((0, 2))
        _refine_kernel(ob, db, np.ascontiguousarray(tri, dtype=np.int64), self._tri, self._fn,
                       self._faces, none3 if self._vn is None else self._vn,
                       none2 if self._uv is None else self._uv, np.ascontiguousarray(R, dtype=np.float64),
                       t, normal, uv)
        return t, normal, uv

    def describe(self) -> str:
        return f"Mesh ({self.n_faces} triangles{', ' + self.source if self.source else ''})"


@numba.njit(cache=True, error_model="numpy")
def _plane_t_kernel(o, d, tri, v0, fn, t_out):  # pragma: no cover - compiled
    """t_out[i]: ray i's parameter on the plane of triangle ``tri[i]`` (``(v0 - o) . n / (d . n)``),
    ``inf`` for a miss (-1), a degenerate triangle (zero normal) or ``t <= 1e-9``."""
    shared = o.shape[0] == 1
    for i in range(d.shape[0]):
        f = tri[i]
        t_out[i] = np.inf
        if f < 0:
            continue
        j = 0 if shared else i
        n0, n1, n2 = fn[f, 0], fn[f, 1], fn[f, 2]
        if not (n0 * n0 + n1 * n1 + n2 * n2) > 0:
            continue
        ti = (((v0[f, 0] - o[j, 0]) * n0 + (v0[f, 1] - o[j, 1]) * n1 + (v0[f, 2] - o[j, 2]) * n2)
              / (d[i, 0] * n0 + d[i, 1] * n1 + d[i, 2] * n2))
        if ti > 1e-9 and ti < np.inf:
            t_out[i] = ti


@numba.njit(cache=True, error_model="numpy")
def _refine_kernel(o, d, tri, tris, fn, faces, vn, uvv, R, t_out, n_out, uv_out):  # pragma: no cover
    """Per ray, from its Embree triangle ``tri[i]`` (-1 = miss): ``t`` on the triangle's plane
    (double precision), the hit's world normal (face normal, or barycentric-interpolated vertex
    normals ``vn`` when given) and material uv (barycentric-interpolated vertex ``uvv`` when
    given, else the body-frame ``(x, y)`` of the hit). Misses: inf / NaN / NaN."""
    shared = o.shape[0] == 1
    smooth = vn.shape[0] > 0
    has_uv = uvv.shape[0] > 0
    nan = np.nan
    for i in range(d.shape[0]):
        f = tri[i]
        if f < 0:
            t_out[i] = np.inf
            n_out[i, 0] = nan
            n_out[i, 1] = nan
            n_out[i, 2] = nan
            uv_out[i, 0] = nan
            uv_out[i, 1] = nan
            continue
        j = 0 if shared else i
        n0, n1, n2 = fn[f, 0], fn[f, 1], fn[f, 2]
        ti = (((tris[f, 0, 0] - o[j, 0]) * n0 + (tris[f, 0, 1] - o[j, 1]) * n1
               + (tris[f, 0, 2] - o[j, 2]) * n2) / (d[i, 0] * n0 + d[i, 1] * n1 + d[i, 2] * n2))
        t_out[i] = ti
        p0 = o[j, 0] + ti * d[i, 0]
        p1 = o[j, 1] + ti * d[i, 1]
        p2 = o[j, 2] + ti * d[i, 2]
        if smooth or has_uv:  # barycentric coordinates of the hit in its triangle
            a0, a1, a2 = tris[f, 0, 0], tris[f, 0, 1], tris[f, 0, 2]
            e0 = (tris[f, 1, 0] - a0, tris[f, 1, 1] - a1, tris[f, 1, 2] - a2)
            e1 = (tris[f, 2, 0] - a0, tris[f, 2, 1] - a1, tris[f, 2, 2] - a2)
            e2 = (p0 - a0, p1 - a1, p2 - a2)
            d00 = e0[0] * e0[0] + e0[1] * e0[1] + e0[2] * e0[2]
            d01 = e0[0] * e1[0] + e0[1] * e1[1] + e0[2] * e1[2]
            d11 = e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]
            d20 = e2[0] * e0[0] + e2[1] * e0[1] + e2[2] * e0[2]
            d21 = e2[0] * e1[0] + e2[1] * e1[1] + e2[2] * e1[2]
            den = d00 * d11 - d01 * d01
            bv = (d11 * d20 - d01 * d21) / den
            bw = (d00 * d21 - d01 * d20) / den
            bu = 1 - bv - bw
            if smooth:
                a, b, c = faces[f, 0], faces[f, 1], faces[f, 2]
                n0 = bu * vn[a, 0] + bv * vn[b, 0] + bw * vn[c, 0]
                n1 = bu * vn[a, 1] + bv * vn[b, 1] + bw * vn[c, 1]
                n2 = bu * vn[a, 2] + bv * vn[b, 2] + bw * vn[c, 2]
            if has_uv:
                a, b, c = faces[f, 0], faces[f, 1], faces[f, 2]
                uv_out[i, 0] = bu * uvv[a, 0] + bv * uvv[b, 0] + bw * uvv[c, 0]
                uv_out[i, 1] = bu * uvv[a, 1] + bv * uvv[b, 1] + bw * uvv[c, 1]
        if not has_uv:
            uv_out[i, 0] = p0
            uv_out[i, 1] = p1
        for k in range(3):  # body -> world: R @ n
            n_out[i, k] = R[k, 0] * n0 + R[k, 1] * n1 + R[k, 2] * n2
