"""Meshing a fused cloud: screened Poisson (Open3D) with density trimming, and its figures
(triangle and vertex counts, watertightness, area)."""
from __future__ import annotations

import numpy as np
import open3d as o3d
from scipy.spatial import cKDTree


def poisson_mesh(points, voxel: float, depth: int = 8, trim_quantile: float = 0.05,
                 camera=(0.0, 0.0, 0.0)) -> o3d.geometry.TriangleMesh:
    """Screened Poisson surface (Kazhdan & Hoppe 2013) of ``points`` (M, 3) mm; normals estimated
    over 3 ``voxel`` and oriented towards ``camera`` (the model frame's camera, view 0);
    vertices of support density below the
    ``trim_quantile`` quantile, or farther than 2 ``voxel`` from every point, are removed
    (the surface Poisson invents over holes and beyond the
    scanned border)."""
    pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(points, float)))
    pc.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=3 * voxel, max_nn=30))
    pc.orient_normals_towards_camera_location(np.asarray(camera, float))
    mesh, support = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(pc, depth=depth)
    dens = np.asarray(support, float)
    if trim_quantile > 0:
        mesh.remove_vertices_by_mask(dens < np.quantile(dens, trim_quantile))
    far, _ = cKDTree(np.asarray(points, float)).query(np.asarray(mesh.vertices))
    mesh.remove_vertices_by_mask(far > 2 * voxel)
    mesh.remove_unreferenced_vertices()
    mesh.compute_vertex_normals()
    return mesh


def mesh_figures(mesh: o3d.geometry.TriangleMesh) -> dict:
    """Triangle and vertex counts, watertight, edge-manifold, surface area (mm²)."""
    return {"triangles": len(mesh.triangles), "vertices": len(mesh.vertices),
            "watertight": bool(mesh.is_watertight()), "edge_manifold": bool(mesh.is_edge_manifold()),
            "area_mm2": float(mesh.get_surface_area())}
