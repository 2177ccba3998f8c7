"""``fringe3d patterns``: files written, manifest, JSON summary, errors."""
import json
import math

import numpy as np

from fringe3d.cli import main
from fringe3d.io.images import read_image
from fringe3d.patterns import render_set
from fringe3d.patterns.manifest import PatternSet


def test_patterns_command_writes_pngs_matching_render_set_and_the_manifest(tmp_path):
    out = tmp_path / "pats"
    assert main(["patterns", "--set", "three-frequency", "--direction", "h", "--width", "64", "--height", "48",
                 "-o", str(out), "-q"]) == 0
    ps = PatternSet.load(out)
    assert len(ps) == 15 and ps.plan("h").method == "heterodyne"
    files = sorted(out.glob("*.png"))
    assert [f.name for f in files] == [f"{i:05d}.png" for i in range(15)]
    np.testing.assert_array_equal(np.stack([read_image(f) for f in files]), render_set(ps))


def test_patterns_command_angle_in_degrees_and_one_bit_kind(tmp_path, capsys):
    out = tmp_path / "p"
    assert main(["patterns", "--set", "phase-shift", "--period", "20.5", "--steps", "4", "--direction", "d",
                 "--angle", "30", "--kind", "bayer", "--width", "50", "--height", "40", "-o", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["frames"] == 4 and summary["bit_depth"] == 1
    ps = PatternSet.load(out)
    assert ps.frames[0].angle == math.radians(30) and ps.frames[0].period == 20.5
    assert set(np.unique(read_image(out / "00002.png"))) <= {0, 255}


def test_patterns_command_optimal_angle_needs_angle_and_writes_31(tmp_path, capsys):
    assert main(["patterns", "--set", "optimal-angle", "-o", str(tmp_path / "x")]) == 2
    assert "alpha_opt" in capsys.readouterr().err
    assert main(["patterns", "--set", "optimal-angle", "--angle", "80", "--width", "60", "--height", "40",
                 "-o", str(tmp_path / "y"), "-q"]) == 0
    assert len(list((tmp_path / "y").glob("*.png"))) == 31


def test_patterns_command_rejects_unknown_set_and_sinusoid_at_one_bit(tmp_path, capsys):
    assert main(["patterns", "--set", "zebra", "-o", str(tmp_path)]) == 2
    assert "unknown pattern set 'zebra'" in capsys.readouterr().err
    assert main(["patterns", "--set", "ftp", "--bits", "1", "-o", str(tmp_path)]) == 2
    assert "1-bit output needs a binary kind" in capsys.readouterr().err


def test_rewriting_a_set_needs_overwrite_and_then_leaves_no_stale_pngs(tmp_path):
    assert main(["patterns", "--set", "three-frequency", "--width", "40", "--height", "30",
                 "-o", str(tmp_path), "-q"]) == 0
    before = sorted(f.name for f in tmp_path.glob("*.png"))
    assert main(["patterns", "--set", "ftp", "--width", "40", "--height", "30", "-o", str(tmp_path), "-q"]) == 2
    assert sorted(f.name for f in tmp_path.glob("*.png")) == before and len(before) == 15
    assert main(["patterns", "--set", "ftp", "--width", "40", "--height", "30", "-o", str(tmp_path), "-q",
                 "--overwrite"]) == 0
    assert [f.name for f in tmp_path.glob("*.png")] == ["00000.png"]


def test_patterns_command_hierarchical_set(tmp_path):
    assert main(["patterns", "--set", "hierarchical", "--period", "16,128,1024", "--steps", "4",
                 "--width", "64", "--height", "48", "-o", str(tmp_path), "-q"]) == 0
    ps = PatternSet.load(tmp_path)
    assert ps.plan("v").method == "hierarchical" and len(ps) == 12


def test_patterns_direction_v_h_writes_both_directions_of_any_set_into_one_manifest(tmp_path):
    from fringe3d.decode import decode

    for set_name in ("phase-shift", "psp-gray", "gray-code", "two-frequency", "hybrid", "ftp"):
        out = tmp_path / set_name
        assert main(["patterns", "--set", set_name, "--direction", "v,h", "--width", "64", "--height", "48",
                     "-o", str(out), "-q"]) == 0
        ps = PatternSet.load(out)
        assert [p.direction for p in ps.plans] == ["v", "h"] and ps.directions() == ["v", "h"], set_name
        one = {d: PatternSet.load(_single(tmp_path, set_name, d)) for d in ("v", "h")}
        assert ps.frames == one["v"].frames + one["h"].frames, set_name
    # a camera seeing the projector 1:1 decodes both projector coordinates from the written set
    ps = PatternSet.load(tmp_path / "psp-gray")
    frames = np.stack([read_image(f) for f in sorted((tmp_path / "psp-gray").glob("*.png"))]) // 2 + 40
    d = decode(frames, ps)
    v, u = np.mgrid[0:48, 0:64]
    np.testing.assert_allclose(d.projector_coordinate("v")[d.mask["v"]], u[d.mask["v"]], atol=0.05)
    np.testing.assert_allclose(d.projector_coordinate("h")[d.mask["h"]], v[d.mask["h"]], atol=0.05)
    assert d.mask["v"].mean() > 0.75 and d.mask["h"].mean() > 0.75  # the rim of the 64x48 image is masked


def _single(tmp_path, set_name: str, direction: str):
    out = tmp_path / f"{set_name}-{direction}"
    assert main(["patterns", "--set", set_name, "--direction", direction, "--width", "64", "--height", "48",
                 "-o", str(out), "-q"]) == 0
    return out
