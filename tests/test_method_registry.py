"""One method registry (issue 24): a method registered from outside the package (one function and
one ``register_method`` call) is accepted by a manifest, ``decode --method``, ``reconstruct`` and
listed by ``--help``; its 3D matches the simulator's truth. The built-in facts, the functions table
and the user guide's table agree."""
from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest
import tifffile

from fringe3d.commands.vocabulary import shown
from fringe3d.cli import main
from fringe3d.decode import METHODS, DecodeContext, Unwrapped, register_method, with_method
from fringe3d.decode.context import combined_mask
from fringe3d.patterns import sets
from fringe3d.patterns.manifest import DirectionPlan, PatternSet
from fringe3d.patterns.method_registry import BUILTIN_METHODS, method_names, methods_table, unregister
from fringe3d.sim import simulate_capture
from fringe3d.unwrap.temporal import hierarchical

W, H = 256, 200       # the tiny preset's projector
NAME = "outside_hierarchy"
PERIODS = (18.0, 144.0, 1024.0)
DOCS = Path(__file__).resolve().parents[1] / "docs" / "user-guide.md"


def unwrap_outside(ctx: DecodeContext) -> Unwrapped:
    """A method written outside fringe3d: every group of the plan, coarse to fine (Eq. 1.5)."""
    groups = ctx.groups_for_plan()
    res = hierarchical([ctx.group_phase(g).phase for g in groups], [g.period for g in groups], w_range=ctx.w_range())
    return Unwrapped(res.phase, combined_mask(ctx, groups))


@pytest.fixture(scope="module")
def registered():
    register_method(NAME, unwrap_outside, groups=3, periods="all")
    yield NAME
    METHODS.pop(NAME, None)
    unregister(NAME)


@pytest.fixture(scope="module")
def capture(registered, tmp_path_factory) -> Path:
    """A tiny-rig capture of the plane whose manifest plan names the registered method."""
    ps = sets.hierarchical(PERIODS, 3, "v", width=W, height=H)
    ps = dataclasses.replace(ps, plans=(dataclasses.replace(ps.plans[0], method=registered),))
    cap = tmp_path_factory.mktemp("registry") / "cap"
    simulate_capture(cap, preset="tiny", scene="plane", patterns=ps, seed=1, progress=False)
    return cap


def run(args, capsys) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err.replace("\n", " ")


def test_a_registered_method_is_read_from_a_manifest(capture, registered):
    ps = PatternSet.load(capture / "manifest.json")
    assert [p.method for p in ps.plans] == [registered]


def test_an_unregistered_name_is_refused_by_the_manifest_naming_the_methods():
    with pytest.raises(ValueError, match="unknown unwrapping method 'not_registered'.*hierarchical"):
        DirectionPlan(direction="v", angle=0.0, method="not_registered")


def test_the_default_plan_of_a_registered_method_follows_its_period_rule(registered):
    ps = with_method(sets.hierarchical(PERIODS, 3, "v", width=W, height=H), registered)
    assert ps.plans[0].method == registered and ps.plans[0].periods == PERIODS


@pytest.mark.parametrize("command", ["decode", "reconstruct"])
def test_help_lists_a_method_registered_before_the_cli_runs(registered, command, capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "2000")  # one line per option: the method names are not wrapped
    code, out, err = run([command, "--help"], capsys)
    assert code == 0, err
    assert f", {shown(registered)}." in out  # listed as the command line spells methods


def test_decode_method_runs_the_registered_function(capture, registered, tmp_path, capsys):
    ours = tmp_path / "ours"
    code, _, err = run(["decode", capture, "--method", registered, "-o", ours, "-q"], capsys)
    assert code == 0, err
    ref = tmp_path / "ref"
    code, _, err = run(["decode", capture, "--method", "hierarchical", "-o", ref, "-q"], capsys)
    assert code == 0, err
    a, b = tifffile.imread(ours / "phase_v.tif"), tifffile.imread(ref / "phase_v.tif")
    both = np.isfinite(a) & np.isfinite(b)
    assert both.mean() > 0.3 and np.allclose(a[both], b[both], atol=1e-6)


def test_reconstruct_with_a_registered_method_matches_the_truth(capture, registered, tmp_path, capsys):
    out = tmp_path / "3d"
    code, _, err = run(["reconstruct", capture, "-c", capture / "rig.json", "-o", out, "--method", registered, "-q"],
                       capsys)
    assert code == 0, err
    code, stdout, err = run(["evaluate", out, "--truth", capture, "--json", "--overwrite"], capsys)
    assert code == 0, err
    assert json.loads(stdout)["truth"]["rms_mm"] < 1.0  # a wrong fringe order is ~100 mm here


def test_the_user_guide_table_is_the_registry():
    assert set(BUILTIN_METHODS) <= set(method_names())
    assert set(BUILTIN_METHODS) == {m for m in METHODS if m != NAME}
    assert methods_table(BUILTIN_METHODS) in DOCS.read_text(encoding="utf-8")
    formats = (DOCS.parent / "file-formats.md").read_text(encoding="utf-8")
    row = next(line for line in formats.splitlines() if line.startswith("| `method` | string |"))
    assert set(re.findall(r"`([a-z_]+)`", row)) - {"method"} == set(BUILTIN_METHODS)
