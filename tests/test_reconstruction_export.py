"""``Reconstruction.to_pyvista`` / ``.to_open3d``: the valid points with colours, normals, quality
and sigma_z, or a clear ImportError naming the extra when the library is missing."""
from __future__ import annotations

import builtins

import numpy as np
import pytest

import fringe3d


@pytest.fixture(scope="module")
def rec(tmp_path_factory):
    folder = tmp_path_factory.mktemp("export") / "cap"
    fringe3d.simulate_capture(folder, preset="tiny", seed=0, progress=False)
    return fringe3d.reconstruct_capture(folder, folder / "rig.json")


def _hide(monkeypatch, name: str) -> None:
    real = builtins.__import__

    def fake(mod, *args, **kwargs):
        if mod == name or mod.startswith(name + "."):
            raise ImportError(f"No module named {name!r}")
        return real(mod, *args, **kwargs)
    monkeypatch.setattr(builtins, "__import__", fake)


def test_reconstruction_carries_the_three_line_fields(rec):
    assert rec.points.shape == (*rec.mask.shape, 3) and rec.texture is not None
    assert rec.quality is not None and rec.sigma_z is not None and rec.sigma_z.shape == rec.mask.shape


def test_to_pyvista_holds_points_colours_quality_and_sigma_z(rec):
    pv = pytest.importorskip("pyvista")
    cloud = rec.to_pyvista()
    assert isinstance(cloud, pv.PolyData) and cloud.n_points == int(rec.mask.sum())
    np.testing.assert_allclose(cloud.points, rec.points[rec.mask], rtol=1e-6)
    for name in ("rgb", "normals", "quality", "sigma_z"):
        assert name in cloud.point_data, name
    np.testing.assert_array_equal(cloud.point_data["quality"], rec.quality[rec.mask])
    np.testing.assert_allclose(cloud.point_data["sigma_z"], rec.sigma_z[rec.mask])
    n = np.linalg.norm(cloud.point_data["normals"], axis=1)
    np.testing.assert_allclose(n, 1.0, atol=1e-4)  # unit normals everywhere, borders included (as in the PLY)


def test_to_open3d_holds_points_colours_and_normals(rec):
    o3d = pytest.importorskip("open3d")
    pcd = rec.to_open3d()
    assert isinstance(pcd, o3d.geometry.PointCloud)
    assert len(pcd.points) == int(rec.mask.sum()) and pcd.has_colors() and pcd.has_normals()
    np.testing.assert_allclose(np.asarray(pcd.points), rec.points[rec.mask], rtol=1e-6)
    assert 0.0 <= np.asarray(pcd.colors).min() and np.asarray(pcd.colors).max() <= 1.0


@pytest.mark.parametrize("method, module", [("to_open3d", "open3d"), ("to_pyvista", "pyvista")])
def test_missing_library_raises_an_import_error_naming_the_extra(rec, monkeypatch, method, module):
    _hide(monkeypatch, module)
    with pytest.raises(ImportError, match=rf"fringe3d\[{module}\]"):
        getattr(rec, method)()
