"""Output safety: nothing written outside the output folder, nothing existing replaced without
--overwrite, an unfinished set never presented as complete, resume only with the same inputs."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.io.capture import read_capture, write_capture
from fringe3d.patterns import render_set, sets
from fringe3d.utils.atomic import atomic_write_text
from fringe3d.utils.output_folder import (
    MARKER_NAME,
    BusyOutputError,
    OutsideOutputError,
    check_complete,
    open_output,
    open_output_file,
)


def snapshot(root: Path) -> dict:
    """Every file under ``root`` with its bytes (what 'nothing changed' is checked against)."""
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture
def capture(tmp_path):
    ps = sets.phase_shift(16, 3, "v", width=48, height=16)
    write_capture(tmp_path / "cap", (render_set(ps) * 200 + 20).astype(np.uint8), ps)
    return tmp_path / "cap"


def test_a_traversal_label_in_a_manifest_is_refused_before_anything_is_written(tmp_path, capture, capsys):
    d = json.loads((capture / "manifest.json").read_text())
    for f in d["frames"]:
        f["direction"] = "../../x"
    for p in d["plans"]:
        p["direction"] = "../../x"
    (capture / "manifest.json").write_text(json.dumps(d))
    before = snapshot(tmp_path)
    assert main(["decode", str(capture), "-o", str(tmp_path / "out")]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "field frames[0].direction" in err and "'../../x'" in err
    assert snapshot(tmp_path) == before and not (tmp_path / "out").exists()


def test_the_write_guard_refuses_paths_that_resolve_outside_the_output(tmp_path):
    (tmp_path / "elsewhere").mkdir()
    with open_output(tmp_path / "out") as o:
        atomic_write_text(o.path / "fine.txt", "ok")
        with pytest.raises(OutsideOutputError, match="outside the output"):
            atomic_write_text(o.path / ".." / "escape.txt", "no")
        os.symlink(tmp_path / "elsewhere", o.path / "link")
        with pytest.raises(OutsideOutputError):
            atomic_write_text(o.path / "link" / "escape.txt", "no")
    assert not (tmp_path / "escape.txt").exists() and not any((tmp_path / "elsewhere").iterdir())
    assert json.loads((tmp_path / "out" / MARKER_NAME).read_text())["complete"] is True


def test_simulate_refuses_a_folder_holding_a_capture_and_overwrite_replaces_it_whole(tmp_path, capture, capsys):
    before = snapshot(capture)
    assert main(["simulate", "-o", str(capture), "--preset", "tiny", "--scene", "plane",
                 "--set", "phase-shift", "-q"]) == 2
    assert "not empty" in capsys.readouterr().err and snapshot(capture) == before
    assert main(["simulate", "-o", str(capture), "--preset", "tiny", "--scene", "plane",
                 "--set", "phase-shift", "-q", "--overwrite"]) == 0
    cap = read_capture(capture)
    assert (capture / "truth").is_dir() and cap.frames.shape[1:] != (16, 48), "the old frames are gone"
    assert len(cap.frames) == len(cap.patterns)
    assert not list(tmp_path.glob(".cap.*")), "no temporary sibling left behind"


def test_simulate_overwrite_through_a_symlinked_frames_folder_leaves_its_target_untouched(tmp_path, capture):
    outside = tmp_path / "precious"
    (capture / "frames").rename(outside)
    os.symlink(outside, capture / "frames")
    before = snapshot(outside)
    assert main(["simulate", "-o", str(capture), "--preset", "tiny", "--scene", "plane",
                 "--set", "phase-shift", "-q", "--overwrite"]) == 0
    assert snapshot(outside) == before
    assert not (capture / "frames").is_symlink()


@pytest.mark.parametrize("inside", ["", "frames"])
def test_an_output_inside_the_input_is_refused(tmp_path, capture, capsys, inside):
    before = snapshot(capture)
    out = capture / inside if inside else capture
    assert main(["decode", str(capture), "-o", str(out), "--overwrite"]) == 2
    assert "inside the input" in " ".join(capsys.readouterr().err.split())
    assert snapshot(capture) == before


def test_an_interrupted_overwrite_keeps_the_old_set(tmp_path):
    out = tmp_path / "out"
    with open_output(out) as o:
        atomic_write_text(o.path / "a.txt", "old")
    before = snapshot(out)
    with pytest.raises(KeyboardInterrupt):
        with open_output(out, overwrite=True) as o:
            atomic_write_text(o.path / "a.txt", "new, half")
            raise KeyboardInterrupt
    assert snapshot(out) == before
    assert [p.name for p in tmp_path.iterdir()] == ["out"]


def test_an_unfinished_set_is_refused_by_readers_and_resumed_only_with_the_same_inputs(tmp_path, capture):
    out = tmp_path / "out"
    with pytest.raises(RuntimeError):
        with open_output(out, inputs=[capture], options={"k": 1}, resumable=True) as o:
            atomic_write_text(o.path / "part.txt", "1 of 2")
            (o.path / ".x.txt.123.part.txt").write_text("stale temporary")
            raise RuntimeError("killed")
    with pytest.raises(ValueError, match="is incomplete"):
        check_complete(out)
    with pytest.raises(ValueError, match="other inputs or options"):
        with open_output(out, inputs=[capture], options={"k": 2}, resumable=True):
            pass
    with pytest.raises(ValueError, match="not empty: it holds the unfinished run .* no longer running"):
        with open_output(out, inputs=[capture], options={"k": 1}):  # not resumable: refused
            pass
    with open_output(out, inputs=[capture], options={"k": 1}, resumable=True) as o:
        assert o.resumed and (o.path / "part.txt").exists()
        assert not (o.path / ".x.txt.123.part.txt").exists(), "stale temporaries are cleaned on resume"
    check_complete(out)


def test_an_unfinished_capture_folder_is_refused_by_decode(tmp_path, capture, capsys):
    (capture / MARKER_NAME).write_text(json.dumps({"format": "fringe3d-output", "complete": False,
                                                   "command": "fringe3d simulate -o cap"}))
    assert main(["decode", str(capture), "-o", str(tmp_path / "out")]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "is incomplete" in err and "fringe3d simulate -o cap" in err


def test_a_second_writer_is_stopped_by_a_lock_that_names_its_holder(tmp_path, capture):
    out = tmp_path / "out"
    code = ("import sys, time; from fringe3d.utils.output_folder import open_output\n"
            f"with open_output({str(out)!r}, resumable=True) as o:\n"
            "    print('in', flush=True); time.sleep(30)\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONPATH": str(Path(__file__).parents[1] / "src")})
    try:
        assert proc.stdout.readline().strip() == "in"
        holder = rf"another fringe3d \(pid {proc.pid}, started [0-9T:+-]+\) is writing"
        with pytest.raises(BusyOutputError, match=holder):
            with open_output(out, resumable=True):
                pass
        with pytest.raises(BusyOutputError, match=holder):  # never "pass --overwrite" against a live run
            with open_output(out, overwrite=True):
                pass
        with pytest.raises(BusyOutputError, match=holder):  # nor "not empty" / "other inputs"
            with open_output(out, inputs=[capture]):
                pass
    finally:
        proc.kill()
        proc.wait()
    time.sleep(0.1)


def test_single_file_outputs_need_overwrite(tmp_path):
    target = tmp_path / "calib.json"
    target.write_text("{}")
    with pytest.raises(ValueError, match="exists; choose another name or pass `overwrite=True`"):
        with open_output_file(target):
            pass
    with open_output_file(target, overwrite=True):
        atomic_write_text(target, '{"new": 1}')
        with pytest.raises(OutsideOutputError):
            atomic_write_text(tmp_path / "other.json", "{}")
    assert json.loads(target.read_text()) == {"new": 1}


def test_report_refuses_a_summary_naming_a_file_outside_its_folder(tmp_path, capsys):
    res = tmp_path / "res"
    res.mkdir()
    secret = tmp_path / "secret.png"
    secret.write_bytes(b"\x89PNG private")
    for name in (str(secret), "../secret.png"):
        (res / "summary.json").write_text(json.dumps({"title": "t", "calibration": {"residual_plot": name}}))
        assert main(["report", str(res), "--overwrite"]) == 2
        err = " ".join(capsys.readouterr().err.split())
        assert "field calibration.residual_plot" in err and "outside the results folder" in err
        assert not (res / "report.html").exists()
