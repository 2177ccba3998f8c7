"""3D never comes silently from a wrapped or relative phase (issue 23): `reconstruct` refuses a
plan unwrapped with ``none`` or ``spatial`` before writing anything and names the absolute
methods; the named fix reconstructs the simulator's truth; `--allow-relative` is marked and
`evaluate` says so; option checks run before any output folder exists."""
from __future__ import annotations

import json
import re
import shlex
import warnings

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.decode import METHODS
from fringe3d.decode.plan_checks import RelativePhaseError
from fringe3d.patterns import sets
from fringe3d.patterns.layouts import opencv_graycode
from fringe3d.patterns.method_registry import is_relative, method_names, relative_methods
from fringe3d.pipeline import reconstruct_capture
from fringe3d.sim import presets, simulate_capture
from fringe3d.sim.truth import Truth
from fringe3d.utils.warning_types import ReconstructionWarning

W, H = 256, 200  # the tiny preset's projector
Z_MIN = 380.0    # the tiny preset's plane lies at z = 400 mm; one 18 px period reaches ~100 mm deeper
#: Every kind of relative plan: (pattern set, --method override or None)
KINDS = {
    "none-phase-shift": (lambda: sets.phase_shift(18, 3, "v", width=W, height=H), None),
    "none-ftp": (lambda: sets.ftp(18, "v", width=W, height=H), None),
    "none-modified-ftp": (lambda: sets.modified_ftp(18, "v", width=W, height=H), None),
    "spatial-override": (lambda: sets.phase_shift(18, 3, "v", width=W, height=H), "spatial"),
    "spatial-ftp-plan": (lambda: sets.ftp(18, "v", width=W, height=H, method="spatial"), None),
}


@pytest.fixture(scope="module")
def captures(tmp_path_factory):
    """One tiny-rig capture of the plane per pattern set (built on first use)."""
    root = tmp_path_factory.mktemp("relative")
    made: dict = {}

    def get(kind: str):
        ps = KINDS[kind][0]()
        key = (ps.name, ps.plans[0].method)  # the "spatial" override shares the "none" plan's capture
        if key not in made:
            made[key] = root / kind
            simulate_capture(made[key], preset="tiny", scene="plane", patterns=ps, seed=1, progress=False)
        return made[key]
    return get


def run(args, capsys):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err.replace("\n", " ")


def truth_rms(out, capture, capsys) -> float:
    code, stdout, err = run(["evaluate", out, "--truth", capture, "--json", "--overwrite"], capsys)
    assert code == 0, err
    return json.loads(stdout)["truth"]["rms_mm"]


def test_one_table_names_every_method_and_gray_code_only_is_absolute():
    assert set(method_names()) == set(METHODS)
    assert set(relative_methods()) == {"none", "spatial"}
    assert not is_relative("gray_code_only") and not is_relative("histogram") and is_relative("none")


@pytest.mark.parametrize("kind", list(KINDS))
def test_relative_plan_is_refused_with_a_fix_that_reconstructs_the_truth(kind, captures, tmp_path, capsys):
    cap = captures(kind)
    method = KINDS[kind][1]
    out = tmp_path / "3d"
    base = ["reconstruct", cap, "-c", cap / "rig.json", "-o", out, "-q"]
    code, _, err = run(base + (["--method", method] if method else []), capsys)
    assert code == 2 and not out.exists()
    assert f"unwrapped with '{method or KINDS[kind][0]().plans[0].method}'" in err and "--allow-relative" in err
    fix = re.search(r"`(--method [^`]+)`", err)
    assert fix is not None and fix.group(1) == "--method geometric --z-min MM"
    code, _, err = run(base + shlex.split(fix.group(1).replace("MM", f"{Z_MIN:g}")), capsys)
    assert code == 0, err
    # a wrong fringe order moves a point by about one period's depth (~100 mm here); the relative
    # phase gave RMS errors of 58-129 m on these captures
    assert truth_rms(out, cap, capsys) < 5.0


def test_the_fix_names_the_depth_the_geometric_constraint_reaches(captures, tmp_path, capsys):
    cap = captures("none-phase-shift")
    code, _, err = run(["reconstruct", cap, "-c", cap / "rig.json", "-o", tmp_path / "o", "--z-min", Z_MIN], capsys)
    assert code == 2 and "`--method geometric --z-min 380`" in err
    reach = float(re.search(r"holds up to z = ([0-9.]+) mm", err).group(1))
    assert Z_MIN < 400.0 < reach  # the plane at 400 mm lies inside the named range


def test_override_of_an_absolute_plan_points_back_to_it(tmp_path, capsys):
    cap = tmp_path / "cap"
    simulate_capture(cap, preset="tiny", scene="plane", patterns=sets.two_frequency(18, 144, "v", width=W, height=H),
                     seed=1, progress=False)
    code, _, err = run(["reconstruct", cap, "-c", cap / "rig.json", "-o", tmp_path / "o", "--method", "none"],
                       capsys)
    assert code == 2 and "own plan 'two_frequency_geometric' is absolute" in err and "drop --method" in err


def test_allow_relative_is_marked_and_evaluate_says_so(captures, tmp_path, capsys):
    cap = captures("none-phase-shift")
    out = tmp_path / "3d"
    code, _, err = run(["reconstruct", cap, "-c", cap / "rig.json", "-o", out, "--allow-relative", "-q"], capsys)
    assert code == 0 and "off by an unknown number of fringe periods" in err
    assert json.loads((out / "reconstruct.json").read_text())["relative_phase"] == ["v"]
    code, stdout, err = run(["evaluate", out, "--truth", cap, "--json"], capsys)
    ev = json.loads(stdout)
    assert code == 0 and ev["relative_phase"] == {"v": "none"} and "relative phase" in err
    assert ev["truth"]["rms_mm"] > 1000.0  # what it flags: the relative 3D is metres off


def test_library_raises_a_typed_error_in_parameter_words(captures):
    cap = captures("none-modified-ftp")
    with pytest.raises(RelativePhaseError, match=r"method='geometric', z_min=MM.*allow_relative=True") as e:
        reconstruct_capture(cap, cap / "rig.json")
    assert [d.direction for d in e.value.directions] == ["v"] and "--" not in str(e.value)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        reconstruct_capture(cap, cap / "rig.json", allow_relative=True)
    assert any(issubclass(w.category, ReconstructionWarning) for w in caught)


@pytest.mark.parametrize("patterns, bad, expected", [
    (lambda: sets.phase_shift(18, 3, "v", width=W, height=H), ["--method", "histogram"], "--z-min"),
    (lambda: sets.two_frequency(18, 144, "v", width=W, height=H), ["--z-min", "-20"], "behind"),
], ids=["histogram-without-z-min", "z-min-behind-the-camera"])
def test_a_refused_sequence_creates_no_folder_and_the_corrected_run_works(patterns, bad, expected, tmp_path, capsys):
    cap = tmp_path / "cap"
    ps = patterns()
    simulate_capture(cap, preset="tiny", scene="plane", patterns=ps, frames=2 * len(ps), seed=1,
                     progress=False)  # two cycles: a resumable sequence, its store made before the first frame
    base = ["reconstruct", cap, "-c", cap / "rig.json", "-o", tmp_path / "seq", "-q"]
    code, _, err = run(base + bad, capsys)
    assert code == 2 and expected in err and not (tmp_path / "seq").exists()
    code, _, err = run(base + [a for a in bad if a not in ("--z-min", "-20")] + ["--z-min", Z_MIN], capsys)
    assert code == 0, err
    assert (tmp_path / "seq" / "points.zarr").is_dir()


def test_reconstruct_takes_every_method_of_the_table_gray_code_only_too(tmp_path, capsys):
    cap = tmp_path / "cap"
    simulate_capture(cap, preset="tiny", scene="plane", patterns=opencv_graycode(W, H), seed=1, progress=False)
    out = tmp_path / "3d"
    code, _, err = run(["reconstruct", cap, "-c", cap / "rig.json", "-o", out, "--method", "gray_code_only", "-q"],
                       capsys)
    assert code == 0, err
    P = np.load(out / "points.npy")
    t = Truth.load(cap / "truth")
    m = np.isfinite(P[..., 2]) & t.mask
    footprint = 400.0 / presets.get("tiny").rig.projector.K[0, 0]  # mm per projector pixel at the plane
    assert m.mean() > 0.5 and np.median(np.linalg.norm(P[m] - t.xyz[m], axis=1)) < footprint
