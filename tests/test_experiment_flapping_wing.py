"""The flapping-wing experiment (quick): figures checked against the simulator's truth and goals."""
import numpy as np
import pytest

from fringe3d.experiments import flapping_wing


@pytest.fixture(scope="module")
def result(quick_experiment):
    return quick_experiment("flapping-wing")


def _table(result, start):
    return next(t for t in result["tables"] if t["title"].startswith(start))


def test_strain_matches_the_analytic_wing_on_truth_maps_and_noise_free_reconstruction(result):
    rows = _table(result, "dominant bending strain")["rows"]
    truth = [r for r in rows if "truth point maps" in r[0]]
    nf = {r[1]: r for r in rows if "noise-free recon., interior" in r[0]}
    assert truth and all(r[3] > 100 for r in truth)         # a real signal: > 100 µε peak
    assert all(r[5] <= 5.0 for r in truth)                  # RMS error ≤ 5 % of peak
    assert nf[31][5] <= 5.0 and nf[31][7] >= 100            # noise-free reconstruction, interior, 31 px fit
    assert nf[31][5] < nf[11][5]                            # larger fits average the FTP ripple
    allpts = [r for r in rows if "noise-free recon., all points" in r[0]][0]
    assert allpts[5] > 3 * nf[31][5]                        # the wing outline is what the interior mask removes
    assert result["goals"]["strain RMS error ≤ 5 % of peak, noise-free reconstruction, interior, 31 px fit"]


def test_tracking_error_per_marker_like_table_6_1(result):
    recon = _table(result, "tracking error, simulate→reconstruct→track (4 3D frames 2.5 ms apart, 25 Hz beat; "
                           "geodesics: Bézier 7×7 Dijkstra + wavefront")["rows"]
    truth = _table(result, "tracking error on noise-free")["rows"]
    assert len(recon) == len(truth) == len(flapping_wing.SIM_MARKERS)
    rms_truth = np.array([r[4:7] for r in truth], float)
    rms_recon = np.array([r[4:7] for r in recon], float)
    assert np.isfinite(rms_recon).all() and (np.array([r[7] for r in recon]) >= 3).all()
    assert rms_truth.max() < 0.02                           # geodesic tracking alone, mm
    assert rms_recon.max() < 0.5                            # the goal, mm


def test_tracking_budget_separates_surface_and_anchor_errors(result):
    rows = {r[0]: np.array(r[1:4], float) for r in _table(result, "tracking error budget")["rows"]}
    exact = rows["right wing: truth maps, exact anchors"]
    assert exact.max() < 0.02                               # the geodesic tracking itself, mm
    assert rows["right wing: truth maps, detected anchors"].max() < 0.3     # anchor centroids ≤ 0.2 px
    recon = rows["right wing: reconstructed maps, detected anchors"]
    np.testing.assert_allclose(recon, np.array(_table(result, "tracking error, simulate")["rows"])[:, 4:7]
                               .astype(float).max(axis=0), rtol=1e-9)
    assert rows["right wing: reconstructed maps, exact anchors"].max() > exact.max()


def test_geodesic_comparison_orders_the_methods(result):
    rows = {r[0]: r for r in _table(result, "geodesic distance")["rows"]}
    wave = rows[flapping_wing.GEO_WAVE]
    edges = rows[flapping_wing.GEO_EDGES]
    assert wave[1] < 0.01                                   # mean relative error, %
    assert 0.2 < edges[1] < 0.7 and edges[3] < 1.35         # stencil quantisation: ≤ sec(atan(1/3)/2) − 1
    assert rows["8-neighbour Dijkstra"][1] > 5 * edges[1]
    heat = next(r for k, r in rows.items() if k.startswith("heat method"))
    assert wave[1] < heat[1] < 3.0


def test_rigid_motion_strain_vanishes_at_exact_material_points(result):
    rows = _table(result, "rigid motion")["rows"]
    assert rows[0][1] < 1e-6
    assert rows[1][1] < 1e-6                                # tracked with the default geodesics
    assert all(r[1] < 5e-6 for r in rows[1:])               # edge-only: limited by its tracking error


def test_noise_floor_is_reported_and_falls_with_the_window(result):
    rows = _table(result, "strain noise floor")["rows"]
    vals = [r[1] for r in rows]
    assert all(np.isfinite(v) and v > 0 for v in vals)
    assert vals[-1] < vals[0]
