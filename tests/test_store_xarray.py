"""The point store opens in xarray with named dimensions and units."""
from __future__ import annotations

import numpy as np
import pytest

from fringe3d.io.store import PointMapStore, StoreSettings


def test_point_store_opens_with_xarray(tmp_path):
    xr = pytest.importorskip("xarray")
    st = PointMapStore.open(tmp_path / "points.zarr", frames=3, height=4, width=5)
    P = np.arange(4 * 5 * 3, dtype=np.float32).reshape(4, 5, 3)
    st.write(1, P)
    ds = xr.open_zarr(tmp_path / "points.zarr", consolidated=False)
    assert ds["points"].dims == ("frame", "row", "column", "axis")
    assert ds["points"].attrs["units"] == "mm" and ds["points"].attrs["axis_labels"] == ["x", "y", "z"]
    assert ds["done"].dims == ("frame",) and ds["done"].values.tolist() == [0, 1, 0]
    np.testing.assert_array_equal(ds["points"].isel(frame=1).values, P)
    assert np.isnan(ds["points"].isel(frame=0).values).all()
    np.testing.assert_array_equal(PointMapStore.open_existing(tmp_path / "points.zarr").read(1), P)


def test_point_store_opens_with_a_plain_open_zarr_without_warning_and_has_pixel_axis_and_time_coords(tmp_path):
    import warnings

    xr = pytest.importorskip("xarray")
    st = PointMapStore.open(tmp_path / "p.zarr", frames=3, height=4, width=5, times=[0.0, 0.04, 0.08],
                            settings=StoreSettings(sigma=True))
    st.write_frame(2, np.ones((4, 5, 3), np.float32), sigma_z=np.full((4, 5), 0.01, np.float32))
    st.mark_done([2])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the "no consolidated metadata" RuntimeWarning would fail here
        ds = xr.open_zarr(tmp_path / "p.zarr")
    assert ds["axis"].values.tolist() == ["x", "y", "z"]
    assert ds["row"].values.tolist() == [0, 1, 2, 3] and ds["column"].values.tolist() == [0, 1, 2, 3, 4]
    assert ds["time"].dims == ("frame",) and ds["time"].attrs["units"] == "s"
    np.testing.assert_allclose(ds["time"].values, [0.0, 0.04, 0.08])
    assert "time" in ds["points"].coords and "time" in ds["sigma_z"].coords
    assert ds["points"].sel(axis="z").isel(frame=2).values.tolist() == np.ones((4, 5)).tolist()
    assert ds.attrs["completed"] == 1


def test_point_store_without_a_frame_rate_has_no_time_coordinate(tmp_path):
    xr = pytest.importorskip("xarray")
    PointMapStore.open(tmp_path / "p.zarr", frames=2, height=3, width=3)
    ds = xr.open_zarr(tmp_path / "p.zarr")
    assert "time" not in ds.coords and ds["frame"].values.tolist() == [0, 1]


def test_a_store_whose_creation_was_cut_short_is_restarted_with_its_time_coordinate(tmp_path):
    import zarr

    from fringe3d.utils.write_guard import writing_into

    xr = pytest.importorskip("xarray")
    path = tmp_path / "p.zarr"
    zarr.open_group(str(path), mode="w")  # an interrupted run: the group exists, no format recorded yet
    with writing_into(tmp_path):
        PointMapStore.open(path, frames=2, height=3, width=3, times=[0.0, 0.5])
    ds = xr.open_zarr(path)
    np.testing.assert_allclose(ds["time"].values, [0.0, 0.5])
