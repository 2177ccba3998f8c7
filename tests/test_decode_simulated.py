"""Decoder on simulator captures, checked against the simulator's ground-truth phase."""
import numpy as np
import pytest

from fringe3d.decode import DecodeOptions, decode
from fringe3d.io.capture import read_capture
from fringe3d.patterns import sets
from fringe3d.sim.simulate import simulate_capture


def _truth(folder):
    with np.load(folder / "truth" / "truth.npz") as t:
        return {k: t[k] for k in t.files}


@pytest.mark.parametrize("patterns", ["three-frequency", "psp-gray-half"])
def test_simulated_sphere_exact_orders_and_mrad_phase(tmp_path, patterns):
    ps = (sets.psp_with_gray_code(18, steps=4, direction="v", code=sets.CodeFrames(period=9), width=256, height=200)
          if patterns == "psp-gray-half" else patterns)
    simulate_capture(tmp_path / "cap", preset="tiny", scene="sphere", patterns=ps, seed=1, progress=False)
    cap = read_capture(tmp_path / "cap")
    d = decode(cap.frames, cap.patterns, options=DecodeOptions(bit_depth=cap.bit_depth))
    truth = _truth(tmp_path / "cap")
    for direction in d.directions:
        tp = truth[f"phase_{direction}"]
        valid = d.mask[direction] & np.isfinite(tp)
        assert valid.sum() > 0.9 * truth["mask"].sum()      # nearly every lit surface pixel decodes
        err = d.phase[direction][valid] - tp[valid]
        assert np.sum(np.abs(err) > np.pi) == 0               # exact fringe order on every valid pixel
        assert np.sqrt(np.mean(err ** 2)) < 0.02              # rad, 8-bit camera with the preset's noise


@pytest.mark.parametrize("patterns", ["ftp", "modified-ftp"])
def test_simulated_ftp_sign_oriented_by_the_rig(tmp_path, patterns):
    """The tiny rig sees the projector mirrored (phase falls along camera u): without the rig
    FTP returns -phi; with the rig the lobe is chosen so the phase matches the truth."""
    from fringe3d.optics import Rig
    simulate_capture(tmp_path / "cap", preset="tiny", scene="sphere", patterns=patterns, seed=2, progress=False)
    cap = read_capture(tmp_path / "cap")
    truth = _truth(tmp_path / "cap")
    rig = Rig.load(tmp_path / "cap" / "rig.json")
    inner = np.zeros(truth["mask"].shape, bool)
    inner[16:-16, 16:-16] = True
    sel = truth["mask"] & inner & np.isfinite(truth["phase_v"])

    def median_err(d):
        return np.median(np.abs(np.angle(np.exp(1j * (d.wrapped["v"][sel] - truth["phase_v"][sel])))))

    assert median_err(decode(cap.frames, cap.patterns, rig=rig)) < 0.1
    assert median_err(decode(cap.frames, cap.patterns, options=DecodeOptions(ftp_sign=-1))) < 0.1
    assert median_err(decode(cap.frames, cap.patterns)) > 1.0
