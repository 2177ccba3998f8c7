"""The audit's hostile inputs, one per finding: each exits with the documented code and a message
naming the file and field, and nothing outside the output folder changes."""
from __future__ import annotations

import json
import os
import shutil
import signal
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import tifffile

from fringe3d.cli import main
from fringe3d.commands import simulate as simulate_command
from fringe3d.io import capture as capture_io
from fringe3d.io.capture import read_capture
from fringe3d.utils.output_folder import request_interrupt

SRC = Path(__file__).parents[1] / "src"


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    cap = tmp_path_factory.mktemp("sim") / "cap"
    assert main(["simulate", "-o", str(cap), "--preset", "tiny", "--scene", "plane", "-q"]) == 0
    return cap


def _edit_json(path: Path, change) -> None:
    d = json.loads(path.read_text())
    change(d)
    path.write_text(json.dumps(d))


def _rig(change):
    return lambda cap: _edit_json(cap / "rig.json", change)


def _manifest(change):
    return lambda cap: _edit_json(cap / "manifest.json", change)


def _meta(change):
    return lambda cap: _edit_json(cap / "capture.json", change)


def _set(path, value):
    def change(d):
        node = d
        for p in path[:-1]:
            node = node[p]
        node[path[-1]] = value
    return change


def _sixteen_bit_frames(cap):
    for f in sorted((cap / "frames").glob("*.png")):
        import cv2
        img = cv2.imread(str(f), cv2.IMREAD_UNCHANGED).astype(np.uint16) * 257
        cv2.imwrite(str(f), img)
    _edit_json(cap / "capture.json", _set(("bit_depth",), 8))


def _nan_tiff_frames(cap):
    for f in sorted((cap / "frames").glob("*.png")):
        import cv2
        img = cv2.imread(str(f), cv2.IMREAD_UNCHANGED).astype(np.float32)
        img[3, 4] = np.nan
        tifffile.imwrite(f.with_suffix(".tif"), img)
        f.unlink()
    _edit_json(cap / "capture.json", lambda d: d.pop("bit_depth", None))


def _deep_manifest(cap):
    (cap / "manifest.json").write_text('{"width": ' + "[" * 50000 + "]" * 50000 + "}")


def _damaged_truth(cap):
    (cap / "truth" / "truth.npz").write_bytes(b"PK\x03\x04 not a zip")


def _write(rel: str, text: str):
    def damage(cap):
        (cap / rel).parent.mkdir(parents=True, exist_ok=True)
        (cap / rel).write_text(text)
    return damage


def _scene(obj: dict, version: int = 1):
    return _write("scene.json", json.dumps({"format": "fringe3d-scene", "version": version, "objects": [obj]}))


PLANE = {"type": "plane", "point": [0, 0, 300], "normal": [0, 0, -1]}


def _all_phase_steps(value):
    def change(d):
        for f in d["frames"]:
            if f["role"] == "phase":
                f["steps"] = value
    return change


def _calibration_file(version):
    def damage(cap):
        rig = json.loads((cap / "rig.json").read_text())
        (cap / "cal.json").write_text(json.dumps({"format": "fringe3d-calibration", "version": version, "rig": rig}))
    return damage


def _session(board: dict, marker: dict | None = None):
    """A session folder beside the capture: session.json with ``board`` and one pose (the capture)."""
    def damage(cap):
        ses = cap.parent / "session"
        shutil.copytree(cap, ses / "pose_00")
        (ses / "pose_00" / "fringe3d.json").unlink(missing_ok=True)
        (ses / "session.json").write_text(json.dumps({"board": board}))
        if marker is not None:
            (ses / "fringe3d.json").write_text(json.dumps(marker))
    return damage


def _infinite_points(cap):
    p = np.load(cap / "points.npy")
    p[1, 2] = [np.inf, 0, 0]
    p[2, 3, 2] = -np.inf
    np.save(cap / "points.npy", p)


def _result_folder(cap):
    (cap / "rec").mkdir()
    shutil.copy(cap / "points.npy", cap / "rec" / "points.npy")


BOARD = {"cols": 9, "rows": 9, "spacing": 12.0, "radius": 3.0}
UNFINISHED = {"format": "fringe3d-output", "version": 1, "complete": False, "command": "fringe3d capture --session s"}
RECONSTRUCT = ["reconstruct", "{cap}", "-c", "{cap}/rig.json", "-o", "{out}"]
DECODE = ["decode", "{cap}", "-o", "{out}"]
SIMULATE = ["simulate", "--scene", "{cap}/scene.json", "-o", "{out}"]
PATTERNS = ["patterns", "--set", "phase-shift", "-o", "{out}"]
CALIBRATE = ["calibrate", "{cap}/../session", "-o", "{out}.json", "--no-plot"]

CASES = {
    "rig with NaN K": (_rig(_set(("camera", "K", 0, 0), float("nan"))), RECONSTRUCT,
                       r"rig.json.*field camera.K\[0\]\[0\]"),
    "rig with zero K": (_rig(_set(("camera", "K"), [[0, 0, 0], [0, 0, 0], [0, 0, 1]])), RECONSTRUCT,
                        "focal lengths"),
    "rig with a singular projector K": (_rig(_set(("projector", "K"), [[1, 0, 0], [0, 0, 0], [0, 0, 1]])),
                                        RECONSTRUCT, "field projector: .*focal lengths"),
    "rig with NaN t": (_rig(_set(("projector", "t", 1), float("nan"))), RECONSTRUCT, r"field projector.t\[1\]"),
    "rig with a sheared R": (_rig(_set(("projector", "R"), [[1, 0.3, 0], [0, 1, 0], [0, 0, 1]])), RECONSTRUCT,
                             "expected a rotation"),
    "rig of another format": (_rig(_set(("format",), "other-rig")), RECONSTRUCT, "field format"),
    "rig of a newer version": (_rig(_set(("version",), 3)), RECONSTRUCT, "field version"),
    "rig with an unknown field": (_rig(_set(("lens",), "x")), RECONSTRUCT, "field lens: unknown field"),
    "manifest without plans": (_manifest(_set(("plans",), [])), RECONSTRUCT, "no unwrapping plan"),
    "manifest with steps 1e9": (_manifest(_set(("frames", 0, "steps"), 1e9)), DECODE, r"field frames\[0\].steps"),
    "manifest with a string width": (_manifest(_set(("width",), "abc")), DECODE, "field width"),
    "manifest nested 50000 deep": (_deep_manifest, DECODE, "nested too deeply"),
    "16-bit frames with bit_depth 8": (_sixteen_bit_frames, DECODE, "bit_depth says 8"),
    "bit_depth true": (_meta(_set(("bit_depth",), True)), DECODE, "field bit_depth"),
    "NaN frames": (_nan_tiff_frames, DECODE, "NaN or infinite"),
    "min-modulation nan": (None, DECODE + ["--min-modulation", "nan"], "--min-modulation must be a finite"),
    "damaged truth.npz": (_damaged_truth, ["evaluate", "{cap}/points.npy", "--truth", "{cap}", "--plane"], "damaged"),
    "zero-byte point map": (lambda cap: (cap / "points.npy").write_bytes(b""), ["evaluate", "{cap}/points.npy",
                                                                                 "--plane"], r"empty \(0 bytes\)"),
    "board of 10^6 circles": (None, ["calibrate", "{cap}", "--cols", "1000000", "-o", "{out}.json"], "--cols must be"),
    "projector of 10^5 x 10^5": (None, ["patterns", "--width", "100000", "--height", "100000", "-o", "{out}"],
                                 "--width/--height"),
    "output inside the capture": (None, ["decode", "{cap}", "-o", "{cap}/frames", "--overwrite"], "inside the input"),
    # issue 28: exit 0 on invalid input
    "manifest with phase steps 0": (_manifest(_all_phase_steps(0)), DECODE, r"field frames\[\d+\]: .*steps >= 1"),
    "plan with NaN beats": (_manifest(_set(("plans", 0, "options", "beats", 0, 0), float("nan"))), DECODE,
                            r"field plans\[0\].options: .*beats\[0\]\[0\]: expected a finite number"),
    "calibration file of version 99": (_calibration_file(99), ["reconstruct", "{cap}", "-c", "{cap}/cal.json", "-o",
                                                               "{out}"], "cal.json: field format/version: .*99"),
    "scene with steps 10^9": (_scene({"type": "heightfield", "size": [50, 50], "center": [0, 0, 300],
                                      "steps": 10**9}), SIMULATE, r"objects\[0\].steps: expected an integer in"),
    "scene texture of period 0": (_scene({**PLANE, "texture": {"type": "checker", "period": 0}}), SIMULATE,
                                  "texture.*field period: expected a finite number > 0"),
    "scene file of version 99": (_scene(PLANE, version=99), SIMULATE, "scene.json.version: 99 is not supported"),
    "patterns --period inf": (None, PATTERNS + ["--period", "inf"], "--period must be finite numbers > 0"),
    "patterns --dither-size 0": (None, PATTERNS + ["--dither-size", "0"], "--dither-size must be 1..256"),
    "patterns --direction ../../x": (None, PATTERNS + ["--direction", "../../x", "--angle", "30"],
                                     "--direction '../../x': a direction label"),
    "decode --bit-depth 7": (None, DECODE + ["--bit-depth", "7"], "--bit-depth must be one of 8, 10, 12, 14, 16"),
    "decode --max-cycles 0": (None, DECODE + ["--max-cycles", "0"], "--max-cycles must be at least 1"),
    "decode with the calibration of another projector": (_rig(_set(("projector", "height"), 768)),
                                                         DECODE + ["-c", "{cap}/rig.json"],
                                                         "describes a 256x768 projector but the pattern manifest"),
    "decode --ftp-window weird": (None, DECODE + ["--ftp-window", "weird"], "--ftp-window must be one of"),
    "strain --thickness inf": (lambda cap: shutil.copy(cap / "points.npy", cap / "points_00000.npy"),
                               ["strain", "{cap}", "--anchors", "auto", "--thickness", "inf", "-o", "{out}"],
                               "--thickness must be a finite number"),
    "report of a summary without a title": (_write("res/summary.json", '{"stages": []}'),
                                            ["report", "{cap}/res", "-o", "{out}.html"],
                                            "summary.json: field title: required field is missing"),
    "evaluate points holding +-inf": (_infinite_points, ["evaluate", "{cap}/points.npy", "--plane"],
                                      "2 point.s. hold an infinite coordinate"),
    "report of an empty folder": (lambda cap: (cap / "empty").mkdir(), ["report", "{cap}/empty", "-o", "{out}.html"],
                                  "nothing to report in"),
    "evaluate with nothing to evaluate": (_result_folder, ["evaluate", "{cap}/rec"], "nothing to evaluate"),
    "session of an interrupted capture": (_session(BOARD, UNFINISHED), CALIBRATE,
                                          "calibration session .* is incomplete: `fringe3d capture --session s`"),
    "calibration of another projector size": (_rig(_set(("projector", "width"), 1024)), RECONSTRUCT,
                                              "describes a 1024x200 projector but the capture's pattern manifest is "
                                              "256x200"),
    # issue 28: crashes
    "session board spacing a string": (_session({**BOARD, "spacing": "12mm"}), CALIBRATE,
                                       "board: field spacing: expected a finite number > 0"),
    "strain of a 0-byte .npy": (lambda cap: (cap / "points_00000.npy").write_bytes(b""),
                                ["strain", "{cap}", "--anchors", "auto", "-o", "{out}"], r"empty \(0 bytes\)"),
}


def _snapshot(root: Path) -> dict:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("name", sorted(CASES))
def test_hostile_input_exits_2_with_a_message_and_changes_nothing(simulated, tmp_path, capsys, name):
    damage, argv, message = CASES[name]
    cap = tmp_path / "cap"
    shutil.copytree(simulated, cap)
    np.save(cap / "points.npy", np.zeros((4, 4, 3), np.float32))
    if damage is not None:
        damage(cap)
    before = _snapshot(tmp_path)
    out = tmp_path / "out"
    code = main([a.format(cap=cap, out=out) for a in argv])
    err = " ".join(capsys.readouterr().err.split())
    assert code == 2, err
    assert __import__("re").search(message, err), err
    assert "Traceback" not in err
    assert _snapshot(tmp_path) == before, "a file changed or appeared"


def _wait_for(path: Path, proc: subprocess.Popen, seconds: float = 600.0) -> None:
    """Block until ``path`` exists (the command got that far) or fail when ``proc`` ends first; no
    short deadline, so a loaded machine only makes it slower, never flaky."""
    deadline = time.monotonic() + seconds
    while not path.exists():
        assert proc.poll() is None, f"the command ended (rc {proc.returncode}) before {path.name} existed"
        assert time.monotonic() < deadline, f"{path} did not appear within {seconds} s"
        time.sleep(0.05)


def test_ctrl_c_exits_130_says_how_far_it_got_and_keeps_a_resumable_unfinished_capture(tmp_path):
    out = tmp_path / "long"
    proc = subprocess.Popen([sys.executable, "-m", "fringe3d", "simulate", "-o", str(out), "--preset", "tiny",
                             "--scene", "wing", "--frames", "930"],
                            env={**os.environ, "PYTHONPATH": str(SRC)}, stderr=subprocess.PIPE, text=True)
    try:
        _wait_for(out / "frames" / "00000.png", proc)  # writing frames: the CLI's handler is in place
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=600)
    finally:
        proc.kill()
    err = " ".join(err.split())
    assert proc.returncode == 130, err
    assert re.search(r"interrupted; \d+ of 930 done", err), err
    assert "is kept, marked incomplete: run the same command again to resume it" in err, err
    assert "Traceback" not in err
    with pytest.raises(ValueError, match="incomplete"):
        read_capture(out)


def test_ctrl_c_inside_a_compiled_kernel_exits_130_not_as_an_internal_error(tmp_path, monkeypatch, capsys):
    """CPython reports a KeyboardInterrupt raised while numba's dispatcher returns as a SystemError
    ("returned a result with an exception set") whose cause is the interrupt."""
    def kernel_cut_by_ctrl_c(*args, **kwargs):
        try:
            os.kill(os.getpid(), signal.SIGINT)  # the CLI's handler records it and raises KeyboardInterrupt
            time.sleep(5)
        except KeyboardInterrupt as e:
            raise SystemError("CPUDispatcher(<function k>) returned a result with an exception set") from e

    monkeypatch.setattr(simulate_command, "simulate_capture", kernel_cut_by_ctrl_c)
    assert main(["simulate", "-o", str(tmp_path / "out"), "-q"]) == 130
    err = " ".join(capsys.readouterr().err.split())
    assert err.startswith("interrupted") and "internal error" not in err and "SystemError" not in err, err
    assert not (tmp_path / "out").exists(), "the folder this run created (and left empty) is removed"


def test_simulate_interrupted_half_way_resumes_to_a_bit_identical_capture(tmp_path, monkeypatch, capsys):
    argv = ["--preset", "tiny", "--scene", "plane", "--frames", "62", "--noise", "0.02", "--seed", "5", "-q"]
    assert main(["simulate", "-o", str(tmp_path / "whole")] + argv) == 0
    write_image = capture_io.write_image

    def ctrl_c_at_frame_31(path, *args, **kwargs):
        if Path(path).name == "00031.png":
            request_interrupt()
            raise KeyboardInterrupt
        return write_image(path, *args, **kwargs)

    monkeypatch.setattr(capture_io, "write_image", ctrl_c_at_frame_31)
    assert main(["simulate", "-o", str(tmp_path / "resumed")] + argv) == 130
    assert "run the same command again to resume it" in " ".join(capsys.readouterr().err.split())
    kept = sorted(p.name for p in (tmp_path / "resumed" / "frames").glob("*.png"))
    assert "00000.png" in kept and "00031.png" not in kept
    monkeypatch.setattr(capture_io, "write_image", write_image)
    assert main(["simulate", "-o", str(tmp_path / "resumed")] + argv) == 0
    whole, resumed = _bodies(tmp_path / "whole"), _bodies(tmp_path / "resumed")
    assert whole.keys() == resumed.keys() and len(whole) > 62
    assert [k for k in whole if whole[k] != resumed[k]] == []
    read_capture(tmp_path / "resumed")


def _bodies(folder: Path) -> dict:
    """Every file but the output marker; JSON without its provenance (it names the command and time)."""
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file() and p.name != "fringe3d.json":
            data = p.read_bytes()
            if p.suffix == ".json":
                d = json.loads(data)
                d.pop("provenance", None)
                data = json.dumps(d, sort_keys=True).encode()
            out[p.relative_to(folder).as_posix()] = data
    return out


def test_a_board_of_10_9_columns_in_session_json_is_refused_before_opencv_searches(simulated, tmp_path):
    """It spun in OpenCV's grid search, deaf to Ctrl-C; now the board is bounded where it is read."""
    cap = tmp_path / "cap"
    shutil.copytree(simulated, cap)
    _session({**BOARD, "cols": 10**9})(cap)
    proc = subprocess.run([sys.executable, "-m", "fringe3d", "calibrate", str(tmp_path / "session"), "-o",
                           str(tmp_path / "c.json"), "--no-plot", "-q"], env={**os.environ, "PYTHONPATH": str(SRC)},
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2, proc.stderr
    assert "board: field cols: expected a whole number in [2, 100], got 1000000000" in " ".join(proc.stderr.split())
    assert not (tmp_path / "c.json").exists()


def _hold_output(out: Path) -> subprocess.Popen:
    """Another process writing ``out`` (inside open_output) until killed."""
    code = ("import time; from fringe3d.utils.output_folder import open_output\n"
            f"with open_output({str(out)!r}) as o:\n"
            "    (o.path / 'part.txt').write_text('1 of 2'); print('in', flush=True); time.sleep(120)\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONPATH": str(SRC)})
    assert proc.stdout.readline().strip() == "in"
    return proc


@pytest.mark.parametrize("extra", [[], ["--overwrite"]])
def test_a_second_writer_is_told_who_holds_the_output_and_never_to_overwrite_it(tmp_path, capsys, extra):
    out = tmp_path / "pats"
    proc = _hold_output(out)
    try:
        before = _snapshot(tmp_path)
        code = main(["patterns", "--set", "phase-shift", "-o", str(out), "-q"] + extra)
        err = " ".join(capsys.readouterr().err.split())
        assert code == 3, err
        assert re.search(rf"another fringe3d \(pid {proc.pid}, started [0-9T:+-]+\) is writing .*pats", err), err
        assert "--overwrite" not in err and "not empty" not in err
        assert _snapshot(tmp_path) == before, "the live run's files changed"
    finally:
        proc.kill()
        proc.wait()


def test_leftovers_of_a_killed_run_are_cleaned_with_a_notice_and_the_rerun_succeeds(tmp_path, capsys):
    """SIGKILL leaves the marker (complete: false), the lock file and .part temporaries; the pid is gone
    and the lock free, so the same command starts over (patterns) with a warning."""
    out = tmp_path / "pats"
    out.mkdir()
    (out / "fringe3d.json").write_text(json.dumps({"format": "fringe3d-output", "version": 1, "complete": False,
                                                   "command": "fringe3d patterns -o pats", "pid": 999999,
                                                   "resumable": False}))
    (out / ".fringe3d.lock").write_text(json.dumps({"pid": 999999, "started": "2026-01-01T00:00:00+00:00"}))
    (out / ".00002.png.k3j.part.png").write_bytes(b"half a png")
    (out / "00000.png").write_bytes(b"from the killed run")
    assert main(["patterns", "--set", "phase-shift", "-o", str(out), "-q"]) == 0
    err = " ".join(capsys.readouterr().err.split())
    assert "holds the unfinished run of `fringe3d patterns -o pats` (pid 999999" in err and "starting over" in err
    assert not list(out.rglob("*.part*")) and not (out / ".fringe3d.lock").exists()
    assert json.loads((out / "fringe3d.json").read_text())["complete"] is True
    assert (out / "00000.png").read_bytes() != b"from the killed run"
    assert [p.name for p in tmp_path.iterdir()] == ["pats"], "no temporary sibling is left"


def test_a_disk_full_run_removes_the_folder_it_created_and_says_so(tmp_path, monkeypatch, capsys):
    out = tmp_path / "pats"
    replace = os.replace
    calls = []

    def disk_full_at_third_file(src, dst):
        calls.append(dst)
        if len(calls) == 3:
            raise OSError(28, "No space left on device")
        replace(src, dst)

    monkeypatch.setattr(os, "replace", disk_full_at_third_file)
    assert main(["patterns", "--set", "phase-shift", "-o", str(out), "-q"]) == 3
    err = " ".join(capsys.readouterr().err.split())
    assert "No space left on device" in err and f"{out} was removed (this run had created it)" in err, err
    assert list(tmp_path.iterdir()) == []


def test_a_point_store_whose_creation_was_cut_short_is_made_again_when_its_output_resumes(tmp_path):
    """Disk full (or Ctrl-C) between zarr's first files and the store's attributes left a group with no
    format; resuming the reconstruction refused it as 'not a fringe3d point store'."""
    import zarr

    from fringe3d.io.store import PointMapStore
    from fringe3d.utils.write_guard import writing_into

    zarr.open_group(str(tmp_path / "points.zarr"), mode="w").create_array("points", shape=(2, 4, 5, 3),
                                                                          dtype="float32")
    with pytest.raises(ValueError, match="not a fringe3d point store"):  # outside a resumed output: refused
        PointMapStore.open(tmp_path / "points.zarr", 2, 4, 5)
    with writing_into(tmp_path):
        store = PointMapStore.open(tmp_path / "points.zarr", 2, 4, 5)
    assert store.frames == 2 and not store.is_done(0)


def test_a_pattern_set_of_infinite_period_is_refused_by_the_library_too():
    """``period: inf`` was written as ``null`` into manifest.json, which decode then refused."""
    from fringe3d.patterns import sets

    with pytest.raises(ValueError, match="fringe period must be a finite number > 0, got inf"):
        sets.phase_shift(float("inf"), 3, "v", width=64, height=48)
