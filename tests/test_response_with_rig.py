"""The projector response kept with the rig (rig file version 2) and used by ``decode`` and
``reconstruct --compensate response`` without ``--response`` (issue 25), against the simulator's
truth on a gamma-2.2 projector."""
import json

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.decode.result import Decoded
from fringe3d.io.capture import write_capture
from fringe3d.io.images import read_image
from fringe3d.optics import Rig
from fringe3d.patterns import sets
from fringe3d.patterns.gamma import fit_gamma, save_gamma
from fringe3d.phase.psp import wrapped_phase
from fringe3d.radiometry import power_law, rig_response, with_response
from fringe3d.radiometry.ripple_size import mm_per_projector_px
from fringe3d.reconstruct.triangulate import triangulate
from fringe3d.sim import Plane, Scene, presets, render
from fringe3d.sim.virtual_devices import VirtualRigState

PRESET = presets.get("tiny")
PROJ = PRESET.rig.projector


def _scene():
    return Scene([Plane(PRESET.center, (0.1, 0.05, -1.0))])


def _setup(tmp_path):
    """A 3-step + Gray-code capture through a gamma-2.2 projector, its grey-ramp gamma.json and rig.json."""
    s = PRESET.settings.replace(ideal=True, bit_depth=16, read_noise=0.0, shot_noise=False, camera_blur=0.0,
                                gamma=2.2)
    ps = sets.psp_with_gray_code(18, 3, "v", width=PROJ.width, height=PROJ.height)
    frames, truth = render(_scene(), PRESET.rig, ps, s, progress=False)
    write_capture(tmp_path / "cap", frames, ps, {"bit_depth": 16})
    rig = VirtualRigState(PRESET, _scene(), s.replace(bit_depth=8))
    levels = np.arange(0, 256, 15)
    ramp = []
    for k, lv in enumerate(levels):
        rig.set_image(np.full((PROJ.height, PROJ.width), lv, np.uint8))
        ramp.append(rig.exposure_image(0.0, k))
    save_gamma(tmp_path / "gamma.json", fit_gamma(levels, np.stack(ramp), full_scale=255))
    PRESET.rig.save(tmp_path / "rig.json")
    return truth


def test_rig_file_keeps_the_response_and_version_1_files_still_load(tmp_path):
    plain = PRESET.rig.to_dict()
    assert plain["version"] == 1 and Rig.from_dict(plain).projector_response is None
    with_table = with_response(PRESET.rig, power_law(2.2, 17))
    d = with_table.to_dict()
    assert d["version"] == 2
    back = rig_response(Rig.from_dict(json.loads(json.dumps(d))))
    assert np.allclose(back.apply([0.25, 0.5]), power_law(2.2, 17).apply([0.25, 0.5]))
    d["projector_response"]["response"][3] = 0.9  # no longer non-decreasing
    with pytest.raises(ValueError, match="projector_response"):
        Rig.from_dict(d)


def test_response_kept_with_the_rig_compensates_decode_and_reconstruct(tmp_path, capsys):
    truth = _setup(tmp_path)
    assert main(["response", str(tmp_path / "gamma.json"), "-c", str(tmp_path / "rig.json"),
                 "-o", str(tmp_path / "rig-r.json"), "-q"]) == 0
    assert rig_response(Rig.load(tmp_path / "rig-r.json")) is not None
    m = truth.mask
    for flags, name in (([], "raw"), (["--compensate", "response"], "comp")):
        assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / f"dec-{name}"), "-q",
                     "-c", str(tmp_path / "rig-r.json"), *flags]) == 0
        assert main(["reconstruct", str(tmp_path / "cap"), "-o", str(tmp_path / f"rec-{name}"), "-q",
                     "-c", str(tmp_path / "rig-r.json"), *flags]) == 0
    err = {}
    for name in ("raw", "comp"):
        d = Decoded.load(tmp_path / f"dec-{name}")
        ok = m & d.mask["v"]
        ph = float(np.sqrt(np.mean(np.angle(np.exp(1j * (d.wrapped["v"] - truth.phase["v"])))[ok] ** 2)))
        pts = np.load(tmp_path / f"rec-{name}" / "points.npy")
        ok3 = m & np.isfinite(pts[..., 0])
        err[name] = (ph, float(np.sqrt(np.mean(np.sum((pts[ok3] - truth.xyz[ok3]) ** 2, axis=-1)))))
    assert err["comp"][0] < err["raw"][0] / 10
    assert err["comp"][1] < err["raw"][1] / 10


def test_compensate_response_with_a_rig_without_one_exits_2_before_writing(tmp_path, capsys):
    _setup(tmp_path)
    assert main(["reconstruct", str(tmp_path / "cap"), "-o", str(tmp_path / "rec"), "-c", str(tmp_path / "rig.json"),
                 "--compensate", "response"]) == 2
    assert "fringe3d response" in capsys.readouterr().err and not (tmp_path / "rec").exists()


KNEE_X = np.linspace(0.0, 1.0, 33)
KNEE = tuple(np.where(KNEE_X < 0.75, 0.9 * (KNEE_X / 0.75) ** 2, 0.9 + 0.1 * (KNEE_X - 0.75) / 0.25).tolist())


def _project(folder, settings, n: int) -> np.ndarray:
    """The camera frames of the first ``n`` PNGs of a pattern folder, shown by the virtual projector."""
    rig = VirtualRigState(PRESET, _scene(), settings)
    out = []
    for k in range(n):
        rig.set_image(read_image(folder / f"{k:05d}.png"))
        out.append(rig.exposure_image(0.0, k))
    return np.stack(out).astype(float)


def test_patterns_predistorted_by_the_measured_table_cut_a_knee_projectors_phase_error(tmp_path):
    s = PRESET.settings.replace(ideal=True, bit_depth=16, read_noise=0.0, shot_noise=False, camera_blur=0.0,
                                response=KNEE)
    ramp = VirtualRigState(PRESET, _scene(), s.replace(bit_depth=8))
    levels = np.arange(0, 256, 5)
    frames = []
    for k, lv in enumerate(levels):
        ramp.set_image(np.full((PROJ.height, PROJ.width), lv, np.uint8))
        frames.append(ramp.exposure_image(0.0, k))
    save_gamma(tmp_path / "gamma.json", fit_gamma(levels, np.stack(frames), full_scale=255))
    size = ["--width", str(PROJ.width), "--height", str(PROJ.height)]
    common = ["patterns", "--set", "phase-shift", "--period", "18", "--steps", "3", "--direction", "v", *size, "-q"]
    assert main([*common, "-o", str(tmp_path / "plain")]) == 0
    assert main([*common, "--response", str(tmp_path / "gamma.json"), "-o", str(tmp_path / "pre")]) == 0
    ps = sets.phase_shift(18, 3, "v", width=PROJ.width, height=PROJ.height)
    _, truth = render(_scene(), PRESET.rig, ps, s, progress=False)
    m = truth.mask

    def rms(folder):
        ph = wrapped_phase(_project(folder, s, 3)).phase
        return float(np.sqrt(np.mean(np.angle(np.exp(1j * (ph - truth.phase["v"])))[m] ** 2)))

    pre, plain = rms(tmp_path / "pre"), rms(tmp_path / "plain")
    print(f"phase RMS plain {plain:.5f} rad, pre-distorted {pre:.5f} rad")
    assert pre < plain / 5


def test_mm_per_projector_pixel_matches_triangulating_one_pixel_shift_at_the_working_point():
    ps = sets.phase_shift(18, 4, "v", width=PROJ.width, height=PROJ.height)
    _, truth = render(_scene(), PRESET.rig, ps, PRESET.settings.replace(ideal=True), progress=False)
    h, w = truth.mask.shape
    centre = (slice(h // 2 - 2, h // 2 + 3), slice(w // 2 - 2, w // 2 + 3))
    moved = triangulate(PRESET.rig, up=truth.up + 1.0, mask=truth.mask)
    shift = np.linalg.norm(moved[centre] - truth.xyz[centre], axis=-1).mean()
    assert mm_per_projector_px(PRESET.rig, "v") == pytest.approx(shift, rel=0.1)


def test_decode_with_a_rig_reports_the_ripple_in_micrometres(tmp_path, capsys):
    s = PRESET.settings.replace(ideal=True, bit_depth=16, read_noise=0.0, shot_noise=False, camera_blur=0.0,
                                gamma=2.2)
    ps = sets.phase_shift(18, 4, "v", width=PROJ.width, height=PROJ.height)
    frames, _ = render(_scene(), PRESET.rig, ps, s, progress=False)
    write_capture(tmp_path / "cap", frames, ps, {"bit_depth": 16})
    PRESET.rig.save(tmp_path / "rig.json")
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "dec"), "-c", str(tmp_path / "rig.json")]) == 0
    assert "um on the surface" in capsys.readouterr().err
    diag = json.loads((tmp_path / "dec" / "decoded.json").read_text())["info"]["radiometry"]["v"]["diagnostic"]
    assert diag["ripple_um"] == pytest.approx(diag["ripple_px"] * mm_per_projector_px(PRESET.rig, "v") * 1e3)


@pytest.mark.parametrize("gamma", [2.2, 1.0])
def test_report_shows_the_diagnostic_and_the_fix_only_for_a_nonlinear_projector(tmp_path, gamma):
    s = PRESET.settings.replace(ideal=True, bit_depth=16, read_noise=0.0, shot_noise=False, camera_blur=0.0,
                                gamma=gamma)
    ps = sets.phase_shift(18, 4, "v", width=PROJ.width, height=PROJ.height)
    frames, _ = render(_scene(), PRESET.rig, ps, s, progress=False)
    write_capture(tmp_path / "cap", frames, ps, {"bit_depth": 16})
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "dec"), "-q"]) == 0
    assert main(["report", str(tmp_path / "dec"), "-o", str(tmp_path / "page.html"), "-q"]) == 0
    page = (tmp_path / "page.html").read_text()
    assert "Projector nonlinearity" in page and "second-harmonic ratio" in page
    assert ("the projector is nonlinear (gamma ~ 2.20)" in page) == (gamma == 2.2)
