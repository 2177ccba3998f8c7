"""Projector gamma end to end on the virtual rig (projector gamma 2.2, 3-step T=18): ``capture
--gamma`` fits it from a grey ramp, ``patterns --gamma`` pre-compensates, and the phase error
against the simulator's truth drops by more than 10x."""
import json

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.io.capture import read_capture
from fringe3d.patterns.gamma import fit_gamma, precompensate
from fringe3d.phase.psp import wrapped_phase
from fringe3d.sim import Truth

TRUE_GAMMA = 2.2
PROJECTOR = f"virtual:tiny?gamma={TRUE_GAMMA}"
CAMERA = "virtual:tiny?scene=plane"


def test_fit_recovers_a_power_law_from_an_exact_ramp():
    levels = np.arange(0, 256, 15, dtype=np.uint8)
    levels = np.append(levels, 255) if levels[-1] != 255 else levels
    albedo = np.linspace(0.3, 0.9, 20)[:, None] * np.ones((1, 7))
    frames = np.stack([10 + 200 * albedo * (lv / 255) ** 1.8 for lv in levels])
    fit = fit_gamma(levels, frames, full_scale=255)
    assert fit["gamma"] == pytest.approx(1.8, rel=1e-6) and fit["rms_residual"] < 1e-9


def test_precompensation_inverts_the_power_law_to_half_a_level():
    p = np.linspace(0, 1, 1001)
    out = precompensate(p, 2.2).astype(float) / 255
    assert np.max(np.abs(out - p ** (1 / 2.2))) <= 0.5 / 255 + 1e-12


def _phase_rms(cap, truth):
    c = read_capture(cap)
    r = wrapped_phase(c.frames.astype(np.float64), shifts=[f.shift for f in c.patterns.frames])
    err = np.angle(np.exp(1j * (r.phase - truth.phase["v"])))[truth.mask]
    return float(np.sqrt(np.mean(err ** 2)))


def test_gamma_compensation_cuts_the_phase_error_tenfold_and_the_fit_is_within_two_percent(tmp_path, capsys):
    g = tmp_path / "gamma.json"
    assert main(["capture", "-o", str(g), "--gamma", "--projector", PROJECTOR, "--camera", CAMERA, "--json"]) == 0
    fitted = json.loads(capsys.readouterr().out)["gamma"]
    assert json.loads(g.read_text())["format"] == "fringe3d-projector-gamma"
    plain, comp = tmp_path / "plain", tmp_path / "comp"
    common = ["patterns", "--set", "phase-shift", "--period", "18", "--steps", "3", "--width", "256", "--height", "200",
              "-q"]
    assert main(common + ["-o", str(plain)]) == 0
    assert main(common + ["-o", str(comp), "--gamma", str(g)]) == 0
    for pats in (plain, comp):
        assert main(["capture", str(pats), "-o", str(pats) + "-cap", "--projector", PROJECTOR, "--camera", CAMERA,
                     "-q"]) == 0
    sim = tmp_path / "truth"
    assert main(["simulate", "--preset", "tiny", "--scene", "plane", "--set", str(plain / "manifest.json"),
                 "-o", str(sim), "-q"]) == 0
    truth = Truth.load(sim)
    before, after = _phase_rms(str(plain) + "-cap", truth), _phase_rms(str(comp) + "-cap", truth)
    print(f"virtual rig, projector gamma {TRUE_GAMMA}, 3-step T=18: fitted gamma {fitted:.4f} "
          f"({(fitted / TRUE_GAMMA - 1) * 100:+.2f}% vs truth); phase RMS error {before:.4f} rad before, "
          f"{after:.4f} rad after compensation ({before / after:.1f}x lower)")
    assert abs(fitted / TRUE_GAMMA - 1) < 0.02
    assert before / after >= 10


def test_gamma_file_of_another_kind_is_refused(tmp_path, capsys):
    bad = tmp_path / "g.json"
    bad.write_text('{"gamma": 2.2}')
    code = main(["patterns", "--set", "phase-shift", "-o", str(tmp_path / "p"), "--gamma", str(bad)])
    assert code == 2 and "is not a projector gamma file" in " ".join(capsys.readouterr().err.split())
