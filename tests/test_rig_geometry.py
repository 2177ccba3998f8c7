"""The rig's precomputed geometry (fringe3d.optics.rig_geometry): owned by the engine, built once
per rig, and freed with it (no module-level cache keeps a rig alive)."""
from __future__ import annotations

import gc
import warnings
import weakref

import numpy as np
import pytest

from fringe3d.decode import DecodeOptions, decode
from fringe3d.io.capture import read_capture
from fringe3d.optics import Rig
from fringe3d.optics.rays import RayGeometry
from fringe3d.optics.rig_geometry import RigGeometry
from fringe3d.patterns import sets
from fringe3d.reconstruct.depth import triangulator_for
from fringe3d.reconstruct.frame import FrameReconstructor, reconstruction_plans
from fringe3d.reconstruct.triangulate import Triangulator
from fringe3d.sim import simulate_capture
from fringe3d.unwrap import geometric

Z340 = DecodeOptions(z_min=340.0)


@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    """One cycle of a 3-step T=64 capture of the tiny rig's sphere: (frames, geometric plans, rig folder)."""
    folder = tmp_path_factory.mktemp("riggeom") / "cap"
    ps = sets.phase_shift(64, 3, "v", width=256, height=200)
    simulate_capture(folder, preset="tiny", scene="sphere", patterns=ps, cycles=1, seed=5, progress=False)
    cap = read_capture(folder)
    return cap.frames, reconstruction_plans(cap.patterns, "geometric"), folder / "rig.json"


@pytest.fixture
def counted_minimum_phase(monkeypatch):
    """Counts the calls of fringe3d.unwrap.geometric.minimum_phase (the map itself is unchanged)."""
    calls = []
    real = geometric.minimum_phase

    def counting(*args, **kw):
        calls.append(args[1:])
        return real(*args, **kw)
    monkeypatch.setattr(geometric, "minimum_phase", counting)
    return calls


def test_two_engines_sharing_one_rig_geometry_compute_the_minimum_phase_map_once(capture, counted_minimum_phase):
    frames, ps, rig_file = capture
    rig = Rig.load(rig_file)
    geo = RigGeometry(rig)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fused = FrameReconstructor(ps, rig, Z340, geometry=geo)
        decoded = FrameReconstructor(ps, rig, Z340, fast=False, geometry=geo)
        a, b = fused.reconstruct(frames), decoded.reconstruct(frames)
        alone = FrameReconstructor(ps, rig, Z340, fast=False).reconstruct(frames)
    assert fused.fast is not None and decoded.fast is None  # both paths ran
    assert fused.geometry is geo and decoded.geometry is geo
    shared = [c for c in counted_minimum_phase if c == counted_minimum_phase[0]]
    assert len(counted_minimum_phase) == 2 and len(shared) == 2  # once for geo, once for the engine built alone
    assert geo.built["minimum_phase"] == 1
    # the shared map is the one the rig gives (Eq. 4.14-4.19), and sharing changes no point
    g = ps.plans[0]
    mp = geometric.cached_minimum_phase(geo, 340.0, g.periods[0], g.angle)
    np.testing.assert_array_equal(mp.phi_min, geometric.minimum_phase(rig, 340.0, g.periods[0], g.angle).phi_min)
    np.testing.assert_array_equal(b.points, alone.points)
    assert np.isfinite(a.points).any()


def test_deleting_the_engine_frees_its_rig_and_geometry(capture):
    frames, ps, rig_file = capture
    rig = Rig.load(rig_file)
    rig_ref = weakref.ref(rig)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rec = FrameReconstructor(ps, rig, Z340, fast=False)  # decode + closed-form triangulation
        rec.reconstruct(frames)
    geo_ref = weakref.ref(rec.geometry)
    assert rec.geometry.built == {"camera_planes": 1, "minimum_phase": 1, "triangulator": 1}  # the rays shared
    del rec, rig
    gc.collect()
    assert rig_ref() is None and geo_ref() is None


def test_decode_refuses_the_geometry_of_another_rig(capture):
    frames, ps, rig_file = capture
    rig, other = Rig.load(rig_file), Rig.load(rig_file)
    with pytest.raises(ValueError, match="geometry was built for another rig"):
        decode(frames, ps, rig=rig, options=Z340, geometry=RigGeometry(other))


@pytest.fixture
def counted_camera_rays(monkeypatch):
    """Counts the builds of the camera rays (fringe3d.optics.rays.camera_rays; the rays unchanged)."""
    from fringe3d.optics import rays

    calls = []
    real = rays.camera_rays

    def counting(rig):
        calls.append(rig)
        return real(rig)
    monkeypatch.setattr(rays, "camera_rays", counting)
    return calls


def test_the_fused_engine_builds_the_camera_rays_once_for_its_minimum_phase_map_and_its_triangulator(
        capture, counted_camera_rays):
    _, ps, rig_file = capture
    rig = Rig.load(rig_file)
    rec = FrameReconstructor(ps, rig, Z340)
    assert rec.fast is not None and len(counted_camera_rays) == 1
    # the shared rays are the ones each built alone: the map, the kernel's rays, hence every output, unchanged
    mp = geometric.minimum_phase(rig, 340.0, rec.fast.mp.period, rec.fast.mp.angle)
    np.testing.assert_array_equal(rec.fast.mp.phi_min, mp.phi_min)
    np.testing.assert_array_equal(rec.fast.mp.sign, mp.sign)
    alone = Triangulator(rig, rec.fast.tri.angle, warn_distortion=False)
    assert len(counted_camera_rays) == 3  # the two built alone
    np.testing.assert_array_equal(rec.rays[1], alone.D_planes)
    np.testing.assert_array_equal(rec.rays[0], alone.O)


def test_ray_geometries_of_one_rig_geometry_share_one_set_of_rays_whatever_their_angle(capture, counted_camera_rays):
    rig = Rig.load(capture[2])
    geo = RigGeometry(rig)
    a, b = RayGeometry(rig, 0.0, geo), triangulator_for(geo, np.pi / 2)
    assert len(counted_camera_rays) == 1 and a.D_planes is b.D_planes
    with pytest.raises(ValueError, match="another rig"):
        RayGeometry(Rig.load(capture[2]), 0.0, geo)


def test_one_cycle_given_the_checks_rig_geometry_computes_the_minimum_phase_map_once(capture, counted_minimum_phase):
    """``fringe3d reconstruct`` of one cycle: the command's plan checks, then reconstruct_cycle's own
    checks and engine, all on one RigGeometry: one minimum phase map, the points of a Rig passed alone."""
    from fringe3d.decode.plan_checks import check_plans
    from fringe3d.pipeline import CycleSettings, reconstruct_cycle

    _, ps, rig_file = capture
    cap = read_capture(rig_file.parent, max_cycles=1)
    rig = Rig.load(rig_file)
    geo = RigGeometry(rig)
    settings = CycleSettings(Z340, "geometric")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_plans(ps, rig, Z340.z_min, geometry=geo)  # as the command does before writing
        shared = reconstruct_cycle(cap, geo, settings)
        assert len(counted_minimum_phase) == 1 and geo.built["minimum_phase"] == 1
        alone = reconstruct_cycle(cap, Rig.load(rig_file), settings)
    assert len(counted_minimum_phase) == 2  # the Rig passed alone: its own map, once
    np.testing.assert_array_equal(shared.points, alone.points)
    assert np.isfinite(shared.points).any()
