"""HDR figures: valid share and 3D RMS against truth with one exposure vs a fused bracket.

For a scene (``shiny-part``, ``printed-part``, :mod:`fringe3d.sim.catalog`) the virtual rig renders
one pattern cycle per exposure time (:func:`fringe3d.sim.bracket.render_bracket`, EMVA 1288 camera
noise). Each single exposure, and the fusion (:func:`fringe3d.phase.exposure_fusion.fuse_exposures`)
of every pair and of all three, is reconstructed (:func:`fringe3d.pipeline.reconstruct_cycle`)
and compared with the simulator's truth:

* ``valid``: share of the *measurable surface* that is reconstructed; the measurable surface is
  what the rig reconstructs of the same geometry made matte, white and noiseless (float frames,
  no saturation), so that silhouette edges, shadows and the projector's border, which no exposure
  recovers, do not count;
* ``rms_mm``, ``median_mm``: 3D RMS and median error (mm) over the pixels the row keeps;
* ``rms_on_best_mm``: the HDR rows' RMS over the pixels kept by the best single exposure (the one
  with the largest valid share), the like-for-like comparison with that exposure's ``rms_mm``.
"""
from __future__ import annotations

import copy
from itertools import combinations

import numpy as np

from fringe3d.io.capture import Capture
from fringe3d.patterns.manifest import PatternSet
from fringe3d.phase.exposure_fusion import fuse_exposures
from fringe3d.phase.quality import saturation_level
from fringe3d.pipeline import reconstruct_cycle
from fringe3d.sim import presets
from fringe3d.sim.bracket import render_bracket
from fringe3d.sim.render import render
from fringe3d.sim.scene import Scene
from fringe3d.sim.simulate import make_patterns, named_scene

#: The bracket of the figures: 1, 4 and 16 times a 0.625 ms base exposure (frame period 10 ms).
EXPOSURES = (0.000625, 0.0025, 0.01)


def hdr_settings(preset, seed: int = 0, gain: float = 4.0):
    """The preset's settings with an EMVA 1288 camera: 10 000 e- full well, 20 e- read noise,
    8 bits, camera gain ``gain`` (a white matte surface saturates the 10 ms exposure)."""
    return preset.settings.replace(noise_model="emva", full_well=10000.0, read_noise_e=20.0, bit_depth=8,
                                   gain=gain, seed=seed)


def _matte_white(scene: Scene) -> Scene:
    objs = [copy.copy(ob) for ob in scene.objects]
    for ob in objs:
        ob.specular, ob.albedo, ob.texture = 0.0, 1.0, None  # type: ignore[attr-defined]
    return Scene(objs, ambient=scene.ambient, name=scene.name + "-matte")


def measurable_surface(scene: Scene, preset, patterns: PatternSet) -> np.ndarray:
    """(H, W) bool: the pixels reconstructed from the scene made matte, white and noiseless."""
    s = preset.settings.replace(bit_depth=None, exposure=0.25 / preset.settings.frame_rate)
    frames, _ = render(_matte_white(scene), preset.rig, patterns, s, progress=False)
    return reconstruct_cycle(Capture(frames=frames, patterns=patterns), preset.rig).mask


def hdr_rows(scene_name: str, preset_name: str = "tiny", exposures=EXPOSURES, seed: int = 0,
             gain: float = 4.0, patterns: str = "three-frequency") -> list[dict]:
    """One row per single exposure and per fused bracket (two longest, all), see the module."""
    p = presets.get(preset_name)
    ps = make_patterns(patterns, p.rig.projector.width, p.rig.projector.height)
    scene = named_scene(scene_name, p)
    stacks, truth = render_bracket(scene, p.rig, ps, hdr_settings(p, seed, gain), exposures)
    surface = measurable_surface(scene, p, ps) & truth.mask
    level = saturation_level(stacks[0], 8)
    n = len(exposures)
    runs: list[tuple[str, np.ndarray, int]] = [(f"1 exposure {exposures[e] * 1e3:g} ms", stacks[e], 1)
                                               for e in range(n)]
    for sel in combinations(range(n), 2) if n > 2 else []:
        label = "HDR " + " + ".join(f"{exposures[e] * 1e3:g}" for e in sel) + " ms"
        runs.append((label, fuse_exposures(stacks[list(sel)], level).frames, 2))
    if n > 1:
        runs.append((f"HDR all {n} exposures", fuse_exposures(stacks, level).frames, n))
    rows, kept = [], []
    for label, frames, k in runs:
        pts = reconstruct_cycle(Capture(frames=frames, patterns=ps, meta={"bit_depth": 8}), p.rig).points
        ok = np.isfinite(pts[..., 0]) & surface
        err = np.linalg.norm(pts - truth.xyz, axis=-1)
        rows.append({"scene": scene_name, "run": label, "exposures": k, "frames": k * len(ps.frames),
                     "valid": float(ok.sum() / surface.sum()),
                     "rms_mm": float(np.sqrt(np.mean(err[ok] ** 2))) if ok.any() else float("nan"),
                     "median_mm": float(np.median(err[ok])) if ok.any() else float("nan")})
        kept.append((ok, err))
    best = int(np.argmax([float(r["valid"]) for r in rows[:n]]))  # type: ignore[arg-type]
    for r, (ok, err) in zip(rows, kept):
        on = ok & kept[best][0]
        r["rms_on_best_mm"] = float(np.sqrt(np.mean(err[on] ** 2))) if on.any() else float("nan")
        r["best_single"] = rows[best]["run"]
    return rows
