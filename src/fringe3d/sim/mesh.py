"""Triangle meshes (OBJ / PLY / STL / ...) ray-cast with Embree through trimesh + embreex.

Embree (the ``embreex`` binding trimesh's ``ray_pyembree`` uses) finds the first triangle along
each ray (single precision); the ray parameter, hit
point and normal are then recomputed in double precision from that triangle's plane, so hits
lie on the mesh to ~1e-12 mm. Meshes are in their own body frame (mm) and posed like every
scene object (``R``, ``center``, optional :class:`RigidMotion`).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .motion import STATIC, RigidMotion
from .scenes import SceneObject, _albedo, _rotation, _vec3, as_rays, rigid_to_body


def load_mesh(path):
    """Read a triangle mesh with trimesh (any format it knows: OBJ, PLY, STL, OFF, GLB...)."""
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
        from trimesh.ray.ray_triangle import RayMeshIntersector
        self.rays = RayMeshIntersector(mesh)

    def first(self, o, d):
        return self.rays.intersects_first(np.broadcast_to(o, d.shape), d)


def _intersector(mesh):
    try:
        return _EmbreeFirstHit(mesh)
    except ImportError:
        return _TrimeshFirstHit(mesh)


class Mesh(SceneObject):
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
            self.source = str(Path(mesh).resolve())
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
        self.center = _vec3(center, "center")
        self.R = np.eye(3) if R is None else _rotation(R)
        self.smooth = bool(smooth)
        self.albedo = _albedo(albedo)
        self.texture = texture
        self.motion = motion
        self._tri = np.asarray(mesh.triangles, dtype=np.float64)  # (F, 3, 3)
        self._fn = np.asarray(mesh.face_normals, dtype=np.float64)
        self._vn = np.asarray(mesh.vertex_normals, dtype=np.float64) if smooth else None
        uv = getattr(getattr(mesh, "visual", None), "uv", None)
        self._uv = None if uv is None or len(uv) != len(mesh.vertices) else np.asarray(uv, float)
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

    def bounding_sphere_body(self):
        lo, hi = self.mesh.bounds
        c = 0.5 * (lo + hi)
        return c, float(np.linalg.norm(self.mesh.vertices - c, axis=1).max())

    def intersect(self, origins, dirs, time: float = 0.0):
        o, d = as_rays(origins, dirs)
        R, c = self.pose(time)
        ob, db = rigid_to_body(o, R, c), rigid_to_body(d, R)
        tri = self._rays.first(ob, db)
        t = np.full(len(d), np.inf)
        normal = np.full(d.shape, np.nan)
        uv = np.full((len(d), 2), np.nan)
        idx = np.flatnonzero(tri >= 0)
        if idx.size:
            f = tri[idx]
            v0 = self._tri[f, 0]
            n = self._fn[f]
            oi = ob[idx] if len(ob) > 1 else ob
            with np.errstate(divide="ignore", invalid="ignore"):
                ti = np.einsum("ij,ij->i", v0 - oi, n) / np.einsum("ij,ij->i", db[idx], n)
            p = oi + ti[:, None] * db[idx]
            t[idx] = ti
            if self.smooth or self._uv is not None:
                bary = _barycentric(p, self._tri[f])
                faces = self.mesh.faces[f]
                if self.smooth:
                    n = np.einsum("ij,ijk->ik", bary, self._vn[faces])
                if self._uv is not None:
                    uv[idx] = np.einsum("ij,ijk->ik", bary, self._uv[faces])
            if self._uv is None:
                uv[idx] = p[:, :2]
            normal[idx] = n @ R.T
        return self._finish(t, normal, uv, d)

    def describe(self) -> str:
        return f"Mesh ({self.n_faces} triangles{', ' + self.source if self.source else ''})"


def _barycentric(p, tri):
    """Barycentric coordinates (M, 3) of points ``p`` (M, 3) in triangles ``tri`` (M, 3, 3)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1, v2 = b - a, c - a, p - a
    d00, d01, d11 = (np.einsum("ij,ij->i", x, y) for x, y in ((v0, v0), (v0, v1), (v1, v1)))
    d20, d21 = np.einsum("ij,ij->i", v2, v0), np.einsum("ij,ij->i", v2, v1)
    den = d00 * d11 - d01 * d01
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    return np.column_stack([1 - v - w, v, w])
