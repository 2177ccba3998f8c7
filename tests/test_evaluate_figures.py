"""Evaluation figures against closed-form truth: synthetic planes and spheres with known noise,
closed-form shape classification, the robust outlier default and truth given as points."""
from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from fringe3d.analyze.classify import guess_shape, is_exact
from fringe3d.analyze.evaluation import evaluate_points, measured_objects
from fringe3d.analyze.truth_points import TruthPoints, truth_point_errors
from fringe3d.cli import main
from fringe3d.utils.console import settings

SIGMA = 0.01  # mm
NORMAL = np.array([0.1, -0.05, -1.0]) / np.linalg.norm([0.1, -0.05, -1.0])


def plane_map(size=300, sigma=SIGMA, seed=0, pitch=0.1):
    rng = np.random.default_rng(seed)
    v, u = np.mgrid[0:size, 0:size].astype(float)
    x, y = (u - size / 2) * pitch, (v - size / 2) * pitch
    z = 500.0 - (NORMAL[0] * x + NORMAL[1] * y) / NORMAL[2]
    noise = rng.normal(0, sigma, (size, size))
    return np.stack([x, y, z], -1) + noise[..., None] * NORMAL, noise


def sphere_before_wall(size=240, r=10.0, c=(0.0, 0.0, 300.0), sigma=SIGMA, seed=1):
    """Pinhole view (f = 600 px) of a sphere in front of a wall at z = 400 mm; radial noise on
    the sphere. Returns the map, the sphere mask and the sphere's radial noise."""
    rng = np.random.default_rng(seed)
    v, u = np.mgrid[0:size, 0:size].astype(float)
    d = np.stack([(u - size / 2) / 600.0, (v - size / 2) / 600.0, np.ones_like(u)], -1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    c = np.asarray(c)
    b = d @ c
    disc = b ** 2 - (c @ c - r * r)
    hit = disc > (0.05 * r) ** 2  # leave out the grazing rim
    s = np.where(hit, b - np.sqrt(np.clip(disc, 0, None)), 400.0 / d[..., 2])
    P = s[..., None] * d
    noise = rng.normal(0, sigma, hit.shape)
    radial = (P - c) / r
    P = np.where(hit[..., None], P + noise[..., None] * radial, P)
    return P, hit, noise[hit]


def test_plane_flatness_and_rms_equal_the_injected_noise():
    P, noise = plane_map()
    ev = evaluate_points(P, plane=True)["plane"]
    assert ev["flatness"] == pytest.approx(np.ptp(noise), rel=2e-3)
    assert ev["rms"] == pytest.approx(np.std(noise), rel=2e-3)
    assert ev["n_points"] == noise.size and ev["outliers"]["excluded_points"] == 0
    assert abs(abs(np.dot(ev["normal"], NORMAL)) - 1) < 1e-8
    assert "warnings" not in ev


def test_sphere_found_by_shape_gives_probing_errors_of_the_noise():
    P, hit, noise = sphere_before_wall()
    ev = evaluate_points(P, sphere=True, diameter=20.0)["sphere"]
    assert ev["n_points"] == pytest.approx(hit.sum(), rel=0.01)  # the sphere, not the wall
    assert abs(ev["size"]) < 3 * SIGMA / np.sqrt(hit.sum()) * 10
    assert ev["rms"] == pytest.approx(np.std(noise), rel=0.02)
    assert ev["form"] == pytest.approx(np.ptp(noise), rel=0.05)
    assert ev["sections"]["row"]["radius"] < 10.0 + 1e-2


def test_closed_form_classification():
    P, hit, _ = sphere_before_wall(sigma=0.0)
    assert guess_shape(P[hit]).kind == "sphere" and is_exact(P[hit], "sphere")
    assert guess_shape(P[~hit]).kind == "plane" and is_exact(P[~hit], "plane")
    assert not is_exact(P[hit], "plane") and not is_exact(P[~hit], "sphere")
    masks = measured_objects(P, "sphere")
    assert len(masks) == 1 and (masks[0] == hit).mean() > 0.99
    assert settings.progress[1] == settings.progress[2]  # the progress count reached its total


def test_gross_outliers_cannot_set_flatness_by_default_but_do_under_the_vdi_rule():
    P, noise = plane_map()
    rng = np.random.default_rng(3)
    k = rng.choice(noise.size, 30, replace=False)
    P.reshape(-1, 3)[k] += 40.0 * NORMAL  # 40 mm fringe-order errors on 0.01 mm data
    clean = np.delete(noise.ravel(), k)
    # organized: the segmentation already cuts the isolated far pixels off the plane
    assert evaluate_points(P, plane=True)["plane"]["flatness"] == pytest.approx(np.ptp(clean), rel=5e-3)
    P = P.reshape(-1, 3)  # a cloud: only the outlier rule stands between them and F
    ev = evaluate_points(P, plane=True)["plane"]
    assert ev["outliers"]["excluded_points"] == 30
    assert ev["flatness"] == pytest.approx(np.ptp(clean), rel=5e-3)
    with pytest.warns(UserWarning, match="x the fit RMS"):
        vdi = evaluate_points(P, plane=True, exclude=0.0)["plane"]
    assert vdi["flatness"] > 39.0 and vdi["warnings"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert evaluate_points(P, plane=True, exclude=0.003)["plane"]["flatness"] < 0.1


def test_truth_as_points_gives_point_to_surface_error():
    P, noise = plane_map(size=200)
    v, u = np.mgrid[0:401, 0:401].astype(float)  # true plane sampled at 0.05 mm, offset grid
    x, y = (u - 200) * 0.05 + 0.013, (v - 200) * 0.05 - 0.021
    true = np.stack([x, y, 500.0 - (NORMAL[0] * x + NORMAL[1] * y) / NORMAL[2]], -1).reshape(-1, 3)
    err = truth_point_errors(P, TruthPoints(true))
    assert err["rms_mm"] == pytest.approx(np.sqrt(np.mean(noise ** 2)), rel=0.01)
    assert err["max_mm"] == pytest.approx(np.abs(noise).max(), rel=0.01)


@pytest.mark.parametrize("suffix", [".npy", ".ply"])
def test_evaluate_cli_with_a_truth_point_file(tmp_path, capsys, suffix):
    from fringe3d.io.pointcloud import write_ply

    P, hit, noise = sphere_before_wall()
    np.save(tmp_path / "points.npy", P.astype(np.float32))
    rng = np.random.default_rng(5)
    d = rng.normal(size=(200_000, 3))
    true = np.array([0.0, 0.0, 300.0]) + 10.0 * d / np.linalg.norm(d, axis=1, keepdims=True)
    truth = tmp_path / f"truth{suffix}"
    np.save(truth, true) if suffix == ".npy" else write_ply(truth, true)
    code = main(["evaluate", str(tmp_path / "points.npy"), "--sphere", "--truth", str(truth), "--json"])
    ev = json.loads(capsys.readouterr().out)
    assert code == 0
    assert ev["sphere"]["true_diameter"] == pytest.approx(20.0, abs=1e-4)  # PLY stores float32
    assert abs(ev["sphere"]["size"]) < 0.01
    assert ev["truth"]["points"] == int(np.isfinite(P[..., 0]).sum())
    code = main(["evaluate", str(tmp_path / "points.npy"), "--sphere", "--truth", str(tmp_path / "points.npy")])
    assert code == 2


def test_with_simulator_truth_a_fringe_order_error_inside_the_object_is_dropped():
    from types import SimpleNamespace

    P, noise = plane_map(size=200)
    clean_xyz = P - noise[..., None] * NORMAL
    truth = SimpleNamespace(xyz=clean_xyz, mask=np.ones(noise.shape, bool), object_id=np.zeros(noise.shape, int))
    P[50:52, 60:80] += 40.0 * NORMAL  # a 2 x 20 px streak one fringe order off, inside the truth's object
    ev = evaluate_points(P, truth, plane=True)
    keep = np.ones(noise.shape, bool)
    keep[50:52, 60:80] = False
    assert ev["plane"]["outliers"]["excluded_points"] == 40
    assert ev["plane"]["flatness"] == pytest.approx(np.ptp(noise[keep]), rel=5e-3)
    assert ev["truth"]["max_mm"] == pytest.approx(40.0, abs=0.1)  # the error against truth still shows it
    with pytest.warns(UserWarning, match="a few far points set it"):
        assert evaluate_points(P, truth, plane=True, exclude=0.0)["plane"]["flatness"] > 39.0
