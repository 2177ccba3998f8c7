"""Shared test helpers: the closed-form flapping wing (tracking / strain tests) and small helpers
several test files use."""
from __future__ import annotations

import fcntl
import os
import pickle
from dataclasses import dataclass

import numpy as np
import pytest

from fringe3d.optics import PinholeDevice, intrinsics

# ----------------------------------------------------------------------------- the analytic wing
# A closed-form flapping, isometrically bending wing seen by a pinhole camera. A flat
# ``span x chord`` mm sheet with material coordinates (s, c) in [0, span] x [0, chord] is rolled
# about an axis parallel to the chord with signed curvature k(t) (an isometry: geodesic distances
# and areas are preserved),
#
#     body(s, c) = (side*sin(k s)/k, c, (1 - cos(k s))/k),
#
# then flapped by a rotation phi(t) about the root line (the body y axis) and placed at ``root``:
# ``world = root + R_y(side*phi) @ body``. Its bending strain at the surface (Eq. 6.11) is
# ``E = (h/2)(k(t) - k(t0))`` along the span, zero across it.


def _rot_y(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


@dataclass
class AnalyticWing:
    """One wing. ``side`` +1 extends towards +x, −1 towards −x; ``root`` (3,) mm world.
    ``curvature(t)`` 1/mm and ``flap(t)`` rad are callables of time (s)."""
    root: np.ndarray
    side: int = 1
    span: float = 150.0
    chord: float = 70.0
    curvature: callable = lambda t: 0.0
    flap: callable = lambda t: 0.0

    def rotation(self, t: float) -> np.ndarray:
        return _rot_y(-self.side * self.flap(t))

    def body(self, s, c, t: float) -> np.ndarray:
        s = np.asarray(s, float)
        c = np.asarray(c, float)
        k = float(self.curvature(t))
        if abs(k) < 1e-9:
            x, z = s, 0.5 * k * s ** 2
        else:
            x, z = np.sin(k * s) / k, (1 - np.cos(k * s)) / k
        return np.stack([self.side * x, c, z], axis=-1)

    def world(self, s, c, t: float) -> np.ndarray:
        """World position (…, 3) mm of material point (s, c) at time t."""
        return self.body(s, c, t) @ self.rotation(t).T + np.asarray(self.root, float)

    def intersect(self, origin: np.ndarray, dirs: np.ndarray, t: float):
        """Ray cast: returns (points (N,3), material (N,2)) with NaN for misses (nearest hit)."""
        R = self.rotation(t)
        o = (np.asarray(origin, float) - self.root) @ R        # body frame (R^T applied)
        d = np.asarray(dirs, float) @ R
        k = float(self.curvature(t))
        n = d.shape[0]
        pts = np.full((n, 3), np.nan)
        mat = np.full((n, 2), np.nan)
        best = np.full(n, np.inf)
        if abs(k) < 1e-7:
            with np.errstate(divide="ignore", invalid="ignore"):
                cands = [-o[2] / d[:, 2]]
        else:
            rk = 1.0 / k
            a = d[:, 0] ** 2 + d[:, 2] ** 2
            b = 2 * (o[0] * d[:, 0] + (o[2] - rk) * d[:, 2])
            cc = o[0] ** 2 + o[2] ** 2 - 2 * o[2] * rk
            disc = b * b - 4 * a * cc
            with np.errstate(invalid="ignore", divide="ignore"):
                sq = np.sqrt(disc)
                qq = -0.5 * (b + np.copysign(sq, b))
                cands = [qq / a, cc / qq]
        for tt in cands:
            p = o + tt[:, None] * d
            if abs(k) < 1e-7:
                s = self.side * p[:, 0]
            else:
                s = np.arctan2(self.side * p[:, 0] * k, 1 - p[:, 2] * k) / k
            cpos = p[:, 1]
            ok = (tt > 0) & (tt < best) & (s >= 0) & (s <= self.span) & (cpos >= 0) & (cpos <= self.chord)
            ok &= np.isfinite(tt)
            best = np.where(ok, tt, best)
            pts[ok] = p[ok] @ R.T + self.root
            mat[ok] = np.stack([s[ok], cpos[ok]], axis=1)
        return pts, mat

    def bending_strain(self, t: float, t0: float, thickness: float) -> float:
        """Span-wise surface bending strain (Eq. 6.11) ``(h/2)(b − B)``; the other principal value
        is 0. With the normal facing the camera (body −z) a positive k curls the sheet away from
        it, so ``b = −k`` and ``E = −(h/2)(k(t) − k(t0))``."""
        return -0.5 * thickness * (float(self.curvature(t)) - float(self.curvature(t0)))


def camera(width: int = 320, height: int = 256, focal: float = 500.0):
    """A distortion-free pinhole camera at the world origin looking along +z (for tests)."""
    return PinholeDevice(K=intrinsics(focal, focal, (width - 1) / 2, (height - 1) / 2), width=width, height=height)


def point_map(wings, camera, t: float, noise: float = 0.0, rng=None):
    """Organized point map (H, W, 3) mm of ``wings`` seen by ``camera`` (PinholeDevice) at time
    t, plus the material coordinates (H, W, 2) and wing index (H, W) (−1 background).
    ``noise``: σ (mm) of Gaussian error along the viewing ray (a reconstruction-noise model)."""
    h, w = camera.height, camera.width
    origin, dirs = camera.rays(camera.pixel_grid().reshape(-1, 2), normalize=True)
    pts = np.full((h * w, 3), np.nan)
    mat = np.full((h * w, 2), np.nan)
    wid = np.full(h * w, -1)
    depth = np.full(h * w, np.inf)
    for i, wing in enumerate(wings):
        p, m = wing.intersect(origin, dirs, t)
        dist = np.linalg.norm(p - origin, axis=1)
        hit = np.isfinite(dist) & (dist < depth)
        pts[hit], mat[hit], wid[hit], depth[hit] = p[hit], m[hit], i, dist[hit]
    if noise > 0:
        rng = rng or np.random.default_rng(0)
        pts += dirs * rng.normal(0.0, noise, size=(h * w, 1))
    return pts.reshape(h, w, 3), mat.reshape(h, w, 2), wid.reshape(h, w)


def flapping_pair(frequency: float = 25.0, amplitude_deg: float = 25.0, k0: float = 1 / 400.0,
                  k1: float = 1 / 300.0, z0: float = 520.0, gap: float = 10.0):
    """Left and right wings beating at ``frequency`` Hz: flap angle amplitude·sin(2πft) and
    span curvature k0 + k1·(1 − cos 2πft)/2 (1/mm), roots ``gap`` mm either side of x = 0."""
    amp = np.deg2rad(amplitude_deg)
    flap = lambda t: amp * np.sin(2 * np.pi * frequency * t)  # noqa: E731
    curv = lambda t: k0 + k1 * 0.5 * (1 - np.cos(2 * np.pi * frequency * t))  # noqa: E731
    return [AnalyticWing(np.array([-gap, -35.0, z0]), -1, curvature=curv, flap=flap),
            AnalyticWing(np.array([gap, -35.0, z0]), +1, curvature=curv, flap=flap)]


#: Material coordinates (s, c) mm of the two anchor dots (leading edge, root and outboard) and
#: of five markers inside the wing (like the dissertation's Fig. 6.1 dataset).
ANCHORS = np.array([[6.0, 6.0], [125.0, 6.0]])
MARKERS = np.array([[40.0, 20.0], [70.0, 45.0], [100.0, 30.0], [130.0, 50.0], [120.0, 15.0]])


def bending_wing() -> AnalyticWing:
    """A wing bending and flapping fast (the strain command's test wing)."""
    return AnalyticWing(np.array([-75.0, -35.0, 560.0]), +1, curvature=lambda t: 1 / 500 + t * 0.2,
                        flap=lambda t: np.deg2rad(600.0) * t)


def write_wing_sequence(folder, times, wing: AnalyticWing | None = None):
    """``points_NNNNN.npy`` + ``texture_NNNNN.npy`` of ``wing`` (default :func:`bending_wing`) at
    ``times`` (s) in ``folder``, seen by :func:`camera`, the textures carrying the two dark
    anchor dots; returns ``(anchors at t = 0 (2, 2) px, wing)``."""
    cam, wing = camera(320, 256, 500.0), wing or bending_wing()
    for i, t in enumerate(times):
        P, M, W = point_map([wing], cam, t)
        tex = np.where(W >= 0, 200.0, 5.0)
        for a in ANCHORS:
            tex[np.hypot(M[..., 0] - a[0], M[..., 1] - a[1]) <= 3.0] = 20.0
        np.save(folder / f"points_{i:05d}.npy", P.astype(np.float32))
        np.save(folder / f"texture_{i:05d}.npy", tex)
    return np.array([cam.project(wing.world(*a, 0.0)) for a in ANCHORS]), wing


# One Xvfb X server for the whole test session (pyglet binds to the first display it opens, so
# every device test must share it): defined once here, started on first use.
from devices_xvfb import xvfb  # noqa: E402,F401  (session fixture)


# ----------------------------------------------------------------------------- shared experiment runs
@pytest.fixture(scope="session")
def quick_experiment(tmp_path_factory):
    """``quick_experiment(name, seed=0)``: ``experiments.get(name).run(quick=True, seed=seed)``,
    computed once per test session and shared by every xdist worker (a pickle under the session's
    shared temporary folder, written under an exclusive ``flock``), returned as a fresh deep copy.

    Each experiment's own test file checks the result against truth and the ``experiment -o`` test
    writes it through the command line, so the run is not repeated for both (issue 24: the suite's
    time)."""
    from fringe3d import experiments

    base = tmp_path_factory.getbasetemp()
    shared = (base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base) / "quick-experiments"
    shared.mkdir(parents=True, exist_ok=True)
    memo: dict = {}
    runs = {n: m.run for n, m in experiments.available().items()}  # before any test replaces one

    def get(name: str, seed: int = 0) -> dict:
        key = f"{name}-seed{seed}"
        if key not in memo:
            with open(shared / f"{key}.lock", "w") as lock:
                fcntl.flock(lock, fcntl.LOCK_EX)
                done = shared / f"{key}.pickle"
                if not done.is_file():
                    result = runs[name](quick=True, seed=seed)
                    part = done.with_suffix(".part")
                    part.write_bytes(pickle.dumps(result))
                    part.replace(done)
                memo[key] = done.read_bytes()
        return pickle.loads(memo[key])

    return get


# ----------------------------------------------------------------------------- small shared fixtures
def cli_ok(*args: str) -> None:
    """Run ``fringe3d ARGS -q`` in-process with its stdout swallowed; it must exit 0."""
    import contextlib
    import io

    from fringe3d.cli import main

    with contextlib.redirect_stdout(io.StringIO()):
        assert main([*args, "-q"]) == 0, args


@pytest.fixture(scope="module")
def pats(tmp_path_factory):
    """A 256x200 three-frequency pattern folder (``fringe3d patterns``)."""
    from fringe3d.cli import main

    out = tmp_path_factory.mktemp("pats") / "three-frequency"
    assert main(["patterns", "--set", "three-frequency", "--width", "256", "--height", "200",
                 "-o", str(out), "-q"]) == 0
    return out
