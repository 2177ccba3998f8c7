"""``fringe3d decode``'s TIFFs as another tool reads them (tifffile): masks as uint8 0/1, phase
and phase sigma NaN outside the mask (no inf or 1e8 placeholders in the background)."""
import numpy as np
import tifffile

from fringe3d.cli import main
from fringe3d.decode import Decoded
from fringe3d.io.capture import write_capture
from fringe3d.patterns import sets

from test_decode_cli import W, capture_frames


def decoded_with_background(tmp_path):
    ps = sets.three_frequency("v")
    frames, _ = capture_frames(ps)
    frames[:, :, : W // 2] = 20  # an unlit background: no modulation, masked
    write_capture(tmp_path / "cap", frames, ps, {"bit_depth": 8})
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "out"), "-q"]) == 0
    return tmp_path / "out", Decoded.load(tmp_path / "out")


def test_decode_tiffs_store_the_mask_as_uint8_and_nan_phase_and_sigma_outside_it(tmp_path):
    out, d = decoded_with_background(tmp_path)
    mask = tifffile.imread(out / "mask_v.tif")
    assert mask.dtype == np.uint8 and set(np.unique(mask)) == {0, 1}
    np.testing.assert_array_equal(mask.astype(bool), d.mask["v"])
    assert not mask[:, : W // 2].any() and mask[:, W // 2 + 2:].all()
    for name in ("phase_v.tif", "phase_sigma_v.tif"):
        img = tifffile.imread(out / name)
        assert img.dtype == np.float32
        np.testing.assert_array_equal(np.isnan(img), ~d.mask["v"])
        assert np.isfinite(img[d.mask["v"]]).all()
    sigma = tifffile.imread(out / "phase_sigma_v.tif")
    np.testing.assert_allclose(sigma[d.mask["v"]], d.phase_sigma["v"][d.mask["v"]], rtol=1e-6)
    assert float(np.nanmax(sigma)) < 1.0  # rad: the lit half is well modulated
