"""``fringe3d strain`` streams its frames and gives the same output as the up-front, full-search run,
as the run that held every result in memory, and with any number of workers."""
import meshio
import numpy as np
import pytest
from conftest import ANCHORS, AnalyticWing, camera, point_map

import fringe3d.analyze.strain as strain_mod
from fringe3d.analyze.anchors import check_anchor, follow_anchors, query_grid
from fringe3d.analyze.geodesic import bezier_geodesic
from fringe3d.analyze.strain import TrackingSettings, wing_sequence
from fringe3d.analyze.wing_strain import StrainSettings, run_strain
from fringe3d.io.export_vtk import grid_triangles, strain_table, write_strain_csv, write_strain_frame
from fringe3d.io.point_sequence import read_point_sequence
from fringe3d.utils.streamed_quantiles import streamed_median, streamed_percentile

TIMES = (0.0, 0.01, 0.02)


@pytest.fixture(scope="module")
def zarr_sequence(tmp_path_factory):
    """Three float32 frames of a bending, flapping wing with dark anchor dots in its texture, in a
    zarr store; the reference anchors (2, 2) px."""
    import zarr

    cam = camera(320, 256, 500.0)
    wing = AnalyticWing(np.array([-75.0, -35.0, 560.0]), +1, curvature=lambda t: 1 / 500 + t * 0.2,
                        flap=lambda t: np.deg2rad(600.0) * t)
    pts, tex = [], []
    for t in TIMES:
        P, M, W = point_map([wing], cam, t)
        x = np.where(W >= 0, 200.0, 5.0)
        for a in ANCHORS:
            x[np.hypot(M[..., 0] - a[0], M[..., 1] - a[1]) <= 3.0] = 20.0
        pts.append(P.astype(np.float32))
        tex.append(x)
    pts, tex = np.stack(pts), np.stack(tex)
    path = tmp_path_factory.mktemp("seq") / "seq.zarr"
    g = zarr.open_group(str(path), mode="w")
    g.create_array("points", shape=pts.shape, dtype="f4")[:] = pts
    g.create_array("texture", shape=tex.shape, dtype="f8")[:] = tex
    return path, pts, np.array([cam.project(wing.world(*a, 0.0)) for a in ANCHORS])


def _full_search_distance_maps(points, anchors_uv, method="bezier", radius=3, stop_distance=None):
    """The distance maps as before the step table: per-anchor full-map search, no stop distance."""
    for a in anchors_uv:
        check_anchor(points, a)
    return bezier_geodesic(points, anchors_uv[0]), bezier_geodesic(points, anchors_uv[1])


def test_streaming_strain_command_gives_the_same_csv_as_the_up_front_full_search(zarr_sequence, tmp_path,
                                                                                 monkeypatch):
    path, pts, anchors0 = zarr_sequence
    arg = ",".join(f"{x:.4f}" for x in anchors0.ravel())
    run_strain(path, arg, tmp_path / "o", StrainSettings(step=6, tracking=TrackingSettings(window=9)), figures=False)
    got = np.genfromtxt(tmp_path / "o" / "strain.csv", delimiter=",", names=True)
    # before: every frame loaded up front as float64, both anchors' maps searched over the whole frame
    seq = read_point_sequence(path)
    maps = [seq[i] for i in range(len(seq))]
    a = np.array([float(x) for x in arg.split(",")]).reshape(2, 2)
    per_frame = follow_anchors(seq.texture, len(seq), [a])[:, 0]
    q = query_grid(maps[0], a, 6, margin=9 // 2)
    monkeypatch.setattr(strain_mod, "distance_maps", _full_search_distance_maps)
    ref = wing_sequence(maps, per_frame, q, 0.1, TrackingSettings(window=9, stop_margin=None))
    want = np.vstack([strain_table(ref.xyz[f], ref.E[f], ref.principal[f], ref.dominant[f], ref.uv[f],
                                   ref.residual[f], ref.ok[f]) for f in range(len(maps))])
    names = [n for n in got.dtype.names if n not in ("frame", "wing")]
    assert len(got) == len(want) and got["ok"].mean() > 0.85
    for k, n in enumerate(names):
        np.testing.assert_allclose(got[n], want[:, k], rtol=1e-7, atol=1e-9, equal_nan=True, err_msg=n)


def test_wing_sequence_reads_one_frame_at_a_time(zarr_sequence):
    path, pts, anchors0 = zarr_sequence
    log = []
    anchors = follow_anchors(lambda i: read_point_sequence(path).texture(i), len(pts), [anchors0])[:, 0]

    class Frames:
        def __len__(self):
            return len(pts)

        def __getitem__(self, i):
            log.append(("read", i))
            return np.asarray(pts[i], np.float64)

    q = query_grid(np.asarray(pts[0], float), anchors0, 8, margin=4)
    wing_sequence(Frames(), anchors, q, 0.1, TrackingSettings(window=9), progress=lambda: log.append("done"))
    # the reference is read first; every other frame is read just before it is processed, never ahead
    assert log == [("read", 0), "done", ("read", 1), "done", ("read", 2), "done"]


def _previous_outputs(path, arg, step, window, out):
    """What ``run_strain`` wrote before streaming: every wing's (F, N) results held in memory
    (:func:`wing_sequence`), then the CSV and the frame files written from them."""
    seq = read_point_sequence(path)
    a = np.array([float(x) for x in arg.split(",")]).reshape(2, 2)
    per_frame = follow_anchors(seq.texture, len(seq), [a])[:, 0]
    q = query_grid(seq[0], a, step, margin=window // 2)
    r = wing_sequence(seq, per_frame, q, 0.1, TrackingSettings(window=window))
    tabs = [strain_table(r.xyz[f], r.E[f], r.principal[f], r.dominant[f], r.uv[f], r.residual[f], r.ok[f])
            for f in range(len(seq))]
    write_strain_csv(out / "strain.csv", np.vstack(tabs), np.repeat(np.arange(len(seq)), len(q)),
                     np.zeros(len(seq) * len(q)))
    for f, tab in enumerate(tabs):
        write_strain_frame(out / f"frame_{f:05d}.vtu", tab, grid_triangles(r.ref_uv, step, r.ok[f]))
    return r


def test_streamed_outputs_equal_the_in_memory_run_and_any_worker_count(zarr_sequence, tmp_path):
    path, pts, anchors0 = zarr_sequence
    arg = ",".join(f"{x:.4f}" for x in anchors0.ravel())
    settings = StrainSettings(step=6, tracking=TrackingSettings(window=9))  # dots not filled (fill_dots=0)
    one = run_strain(path, arg, tmp_path / "w1", settings, figures=True)
    two = run_strain(path, arg, tmp_path / "w2", settings, figures=True, workers=2)
    prev = _previous_outputs(path, arg, 6, 9, tmp_path / "prev")
    # the CSV and every frame's VTU: the very bytes of the in-memory run, with 1 or 2 workers
    want_csv = (tmp_path / "prev" / "strain.csv").read_bytes()
    for run in ("w1", "w2"):
        assert (tmp_path / run / "strain.csv").read_bytes() == want_csv
        for f in range(len(pts)):
            got = meshio.read(tmp_path / run / "vtk" / f"frame_{f:05d}.vtu")
            want = meshio.read(tmp_path / "prev" / f"frame_{f:05d}.vtu")
            np.testing.assert_array_equal(got.points, want.points)
            np.testing.assert_array_equal(got.cells_dict["triangle"], want.cells_dict["triangle"])
            for k in want.point_data:
                np.testing.assert_array_equal(got.point_data[k], want.point_data[k], err_msg=k)
        for name in ("uv", "xyz", "E", "dominant", "residual", "ok"):
            np.testing.assert_array_equal(np.load(tmp_path / run / "arrays" / "wing_0" / f"{name}.npy"),
                                          getattr(prev, name), err_msg=name)
        for f in range(len(pts)):
            assert (tmp_path / run / "maps" / f"strain_{f:05d}.png").read_bytes() == \
                (tmp_path / "w1" / "maps" / f"strain_{f:05d}.png").read_bytes()
    # the summary's statistics: what numpy gives on all the results at once
    ok = prev.ok
    for s in (one, two):
        assert s["tracked_fraction"] == float(np.mean(ok))
        assert s["median_residual_mm"] == float(np.nanmedian(prev.residual[ok]))
        assert s["dominant_strain_p99"] == float(np.nanpercentile(np.abs(prev.dominant[ok]), 99))


def test_streamed_quantiles_equal_numpy_on_the_concatenated_data():
    rng = np.random.default_rng(3)
    for n in (1, 2, 7, 500, 3001):
        x = np.round(rng.standard_cauchy(n), int(rng.integers(0, 3)))   # heavy tails and ties
        parts = np.array_split(x, 5)
        for p in (0, 1, 37.3, 50, 99, 100):
            got = streamed_percentile(lambda parts=parts: iter(parts), p, bins=8, hold=40)
            assert got == float(np.percentile(x, p))
        assert streamed_median(lambda parts=parts: iter(parts), bins=8, hold=40) == float(np.median(x))
    assert np.isnan(streamed_median(lambda: iter([np.empty(0)])))
