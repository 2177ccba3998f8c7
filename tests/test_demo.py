"""`fringe3d demo` runs the whole chain on the tiny virtual rig and its figures agree with truth."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from fringe3d.cli import main


@pytest.fixture(scope="module")
def tiny_demo(tmp_path_factory) -> tuple[Path, dict]:
    out = tmp_path_factory.mktemp("demo")
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(["demo", "--profile", "tiny", "-o", str(out), "--json"])
    assert code == 0
    return out, json.loads(buf.getvalue())


def test_demo_writes_calibration_clouds_figures_and_report(tiny_demo):
    out, _ = tiny_demo
    for name in ("calibration.json", "calibration_residuals.png", "sphere.ply", "sculpture.ply",
                 "error_sphere.png", "summary.json", "report.html"):
        assert (out / name).stat().st_size > 0, name
    assert not list(out.glob("*.part*")), "temporary files left behind"


def test_demo_files_carry_units_and_provenance(tiny_demo):
    from output_checks import check_folder

    out, _ = tiny_demo
    check_folder(out, "demo")


def test_demo_calibration_is_close_to_the_true_rig(tiny_demo):
    _, s = tiny_demo
    figs = s["calibration"]["figures"]
    # tiny rig: 160x128 camera, 6 poses, 8-bit noisy frames
    assert abs(figs["camera focal length error (%)"]) < 2.0
    assert abs(figs["projector focal length error (%)"]) < 2.0
    assert figs["projector position error (mm)"] < 5.0


def test_demo_sphere_and_ball_bar_agree_with_truth(tiny_demo):
    _, s = tiny_demo
    acc = {a["quantity"]: a["value"] for a in s["accuracy"]}
    assert acc["sphere-fit RMS"] < 0.2            # mm, noise-level form error
    assert abs(acc["probing error size P_S"]) < 0.5  # mm
    assert abs(acc["sphere spacing error"]) < 1.0    # mm, over a ~70 mm bar
    assert [st["name"] for st in s["stages"]][0] == "render calibration session"


def test_demo_rejects_unknown_profile_with_exit_code_2(tmp_path, capsys):
    assert main(["demo", "--profile", "huge", "-o", str(tmp_path)]) == 2
    assert "unknown demo profile" in capsys.readouterr().err


def test_demo_reports_unwritable_output_folder(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    code = main(["demo", "--profile", "tiny", "-o", str(blocker / "sub")])
    assert code in (2, 3)
    err = capsys.readouterr().err
    assert "sub" in err or "file" in err


def test_unknown_option_is_a_usage_error(capsys):
    assert main(["demo", "--no-such-option"]) == 2


def test_failing_write_midway_leaves_no_half_written_report(tmp_path, monkeypatch):
    import fringe3d.report.html as html

    def broken(folder):
        raise OSError("disk full (simulated)")
    monkeypatch.setattr(html, "build_report", broken)
    assert main(["demo", "--profile", "tiny", "-o", str(tmp_path), "--quiet"]) == 3
    assert not (tmp_path / "report.html").exists()
    assert not list(tmp_path.glob(".*.part*"))
