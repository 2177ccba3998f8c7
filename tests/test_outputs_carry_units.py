"""Every file the commands write says what it holds: each JSON carries the fringe3d version, the
time, the command line and units; each TIFF a description with its quantity and unit; each PLY
``comment units: mm``. Walks the outputs of simulate, decode, reconstruct, evaluate (and so fails
when a new output forgets them). And one meaning for ``texture``: decode's equals reconstruct's."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import tifffile

from fringe3d.cli import main
from fringe3d.utils.provenance import read_tiff_description
from output_checks import check_json_provenance, check_ply_header, check_tiff_description, outputs


@pytest.fixture(scope="module")
def chain(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("chain")
    cap, dec, rec = root / "cap", root / "dec", root / "rec"
    for args in (["simulate", "-o", str(cap), "--scene", "sphere", "-q"],
                 ["decode", str(cap), "-o", str(dec), "-q"],
                 ["reconstruct", str(cap), "-c", str(cap / "rig.json"), "-o", str(rec), "--ply", "-q"],
                 ["evaluate", str(rec), "--sphere", "--truth", str(cap), "-q"]):
        assert main(args) == 0, args
    return root


def test_every_json_carries_version_time_command_and_units(chain):
    files = outputs(chain, (".json",))
    assert {f.name for f in files} >= {"capture.json", "manifest.json", "rig.json", "truth.json", "decoded.json",
                                       "reconstruct.json", "evaluate.json", "fringe3d.json"}
    for f in files:
        check_json_provenance(f)


def test_every_tiff_names_its_quantity_and_unit(chain):
    files = outputs(chain, (".tif", ".tiff"))
    assert {"texture.tif", "depth.tif", "phase_v.tif", "sigma_z.tif", "sphere_residuals.tif"} <= {f.name for f in files}
    for f in files:
        check_tiff_description(f)
    assert read_tiff_description(chain / "rec" / "depth.tif")["unit"] == "mm"


def test_every_ply_header_names_the_unit_and_the_command(chain):
    files = outputs(chain, (".ply",))
    assert files
    for f in files:
        check_ply_header(f, "reconstruct")


def test_decode_and_reconstruct_write_the_same_texture_a_fraction_of_full_scale(chain):
    from fringe3d.io.capture import read_capture

    a = tifffile.imread(chain / "dec" / "texture.tif")
    b = tifffile.imread(chain / "rec" / "texture.tif")
    np.testing.assert_array_equal(a, b)
    cap = read_capture(chain / "cap")
    white = cap.patterns.indices(kind="white")[0]  # the tiny preset's set has a white frame
    np.testing.assert_allclose(a, cap.frames[white] / 255.0, atol=1e-7)  # 8-bit camera
    assert read_tiff_description(chain / "dec" / "texture.tif")["unit"] == "fraction of full scale"


def test_fused_three_step_path_gives_decode_s_texture_a_plus_b(tmp_path):
    """Without a white frame the texture is A + B (the fringe peak) on both reconstruct paths."""
    from fringe3d.decode import DecodeOptions, decode
    from fringe3d.io.capture import read_capture
    from fringe3d.optics import Rig
    from fringe3d.patterns import sets
    from fringe3d.phase.psp import wrapped_phase
    from fringe3d.reconstruct.sequence import FrameReconstructor, reconstruction_plans
    from fringe3d.sim import simulate_capture

    ps = sets.phase_shift(64, 3, "v", width=256, height=200)
    simulate_capture(tmp_path / "cap", preset="tiny", scene="sphere", patterns=ps, seed=7, progress=False)
    cap = read_capture(tmp_path / "cap")
    rig = Rig.load(tmp_path / "cap" / "rig.json")
    ps = reconstruction_plans(cap.patterns, "geometric")
    opts = DecodeOptions(z_min=340.0, bit_depth=8)
    fast = FrameReconstructor(ps, rig, opts)
    assert fast.fast is not None  # the fused 3-step kernel
    tex = fast.reconstruct(cap.frames, uncertainty=False).texture
    pr = wrapped_phase(cap.frames, shifts=[f.shift for f in ps.frames])
    np.testing.assert_allclose(tex, np.clip((pr.average + pr.modulation) / 255.0, 0, 1), atol=1e-5)
    np.testing.assert_allclose(decode(cap.frames, ps, rig=rig, options=opts).texture, tex, atol=1e-5)


def test_a_moving_scene_s_streamed_truth_carries_provenance_and_units(tmp_path):
    assert main(["simulate", "-o", str(tmp_path / "cap"), "--scene", "falling-balls", "--set", "two-frequency",
                 "-q"]) == 0
    check_json_provenance(tmp_path / "cap" / "truth" / "truth.json")
