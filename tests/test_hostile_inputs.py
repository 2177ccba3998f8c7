"""The audit's hostile inputs, one per finding: each exits with the documented code and a message
naming the file and field, and nothing outside the output folder changes."""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import tifffile

from fringe3d.cli import main
from fringe3d.io.capture import read_capture

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


RECONSTRUCT = ["reconstruct", "{cap}", "-c", "{cap}/rig.json", "-o", "{out}"]
DECODE = ["decode", "{cap}", "-o", "{out}"]

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
    "rig of a newer version": (_rig(_set(("version",), 2)), RECONSTRUCT, "field version"),
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


def test_ctrl_c_exits_130_says_how_far_it_got_and_leaves_nothing_marked_complete(tmp_path):
    out = tmp_path / "long"
    proc = subprocess.Popen([sys.executable, "-m", "fringe3d", "simulate", "-o", str(out), "--preset", "tiny",
                             "--scene", "wing", "--frames", "930"],
                            env={**os.environ, "PYTHONPATH": str(SRC)}, stderr=subprocess.PIPE, text=True)
    try:
        for _ in range(600):  # wait until it is writing (its marker exists), then interrupt
            if (out / "fringe3d.json").exists():
                break
            proc.wait(timeout=0.1) if proc.poll() is not None else __import__("time").sleep(0.1)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == 130, err
    assert "interrupted" in err and "--overwrite" in err
    # interrupted before a frame was written, the folder is removed; after, it stays marked incomplete
    with pytest.raises((ValueError, FileNotFoundError), match="incomplete|does not exist"):
        read_capture(out)
