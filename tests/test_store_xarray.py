"""The point store opens in xarray with named dimensions and units."""
from __future__ import annotations

import numpy as np
import pytest

from fringe3d.io.store import PointMapStore


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
