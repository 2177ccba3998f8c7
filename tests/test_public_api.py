"""The top-level API: every exported name resolves, the version has one source, and the
README's three lines (capture folder -> point cloud) reproduce the simulator's truth."""
from __future__ import annotations

import importlib
import importlib.metadata
import re
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

import fringe3d
from fringe3d.sim.truth import Truth

#: Measured 0.112 mm (tiny preset, seed 0, sensor noise on); the bound leaves margin.
RMS_BOUND_MM = 0.2


@pytest.fixture(scope="module")
def tiny_capture(tmp_path_factory):
    folder = tmp_path_factory.mktemp("api") / "cap"
    fringe3d.simulate_capture(folder, preset="tiny", seed=0, progress=False)
    return folder


def test_every_exported_name_resolves():
    for name in fringe3d.__all__:
        assert getattr(fringe3d, name) is not None, name
    assert set(fringe3d.__all__) <= set(dir(fringe3d))
    with pytest.raises(AttributeError, match="no attribute 'no_such_step'"):
        fringe3d.no_such_step  # noqa: B018


def test_every_exported_name_is_documented_and_no_module():
    for name in fringe3d.__all__:
        value = getattr(fringe3d, name)
        if name == "__version__":
            continue
        assert not isinstance(value, types.ModuleType), f"{name} is a module, not a step"
        assert (value.__doc__ or "").strip(), f"{name} has no docstring"


def test_one_top_level_function_per_command_step():
    steps = {"decode_frames": "fringe3d.decode", "reconstruct_capture": "fringe3d.pipeline",
             "evaluate_points": "fringe3d.analyze", "measure_strain": "fringe3d.analyze",
             "write_report": "fringe3d.report"}
    for name, package in steps.items():
        step = getattr(fringe3d, name)
        assert callable(step) and not isinstance(step, types.ModuleType)
        assert step.__module__.startswith(package), name
        assert name in fringe3d.__doc__, f"{name} is not in the package docstring"
    importlib.import_module("fringe3d.decode")  # importing the sub-package rebinds fringe3d.decode ...
    assert fringe3d.decode_frames is importlib.import_module("fringe3d.decode").decode  # ... not the step


def test_dir_shows_no_helper_or_imported_name():
    names = dir(fringe3d)
    assert {"annotations", "importlib"}.isdisjoint(names)
    leaked = [n for n in names if n.startswith("_") and not (n.startswith("__") and n.endswith("__"))]
    assert leaked == []
    assert set(fringe3d.__all__) <= set(names)


def test_version_comes_from_the_package_metadata():
    assert fringe3d.__version__ == importlib.metadata.version("fringe3d")


def test_import_is_lazy():
    code = "import sys, fringe3d; print(sorted(m for m in sys.modules if m.startswith('fringe3d.')))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_three_lines_from_capture_to_point_cloud(tiny_capture, tmp_path):
    r = fringe3d.reconstruct_capture(tiny_capture, tiny_capture / "rig.json")
    r.save_ply(tmp_path / "cap.ply")
    assert r.points.dtype == np.float32 and r.points.shape == (*r.mask.shape, 3)
    assert (tmp_path / "cap.ply").stat().st_size > 0
    truth = Truth.load(tiny_capture)
    ok = r.mask & truth.mask
    assert ok.mean() > 0.8
    err = np.linalg.norm(r.points[ok] - truth.xyz[ok], axis=-1)
    assert float(np.sqrt(np.mean(err ** 2))) < RMS_BOUND_MM


def test_the_readme_three_lines_run_as_written(tiny_capture, tmp_path, monkeypatch):
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    block = re.search(r"```python\n(import fringe3d\n.*?)```", readme, re.S)
    assert block, "README lost its capture -> point cloud example"
    lines = block.group(1).strip().splitlines()
    assert len(lines) <= 3
    (tmp_path / "cap").symlink_to(tiny_capture, target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    exec(compile(block.group(1), "README.md", "exec"), {})
    assert (tmp_path / "cap.ply").stat().st_size > 0


def test_reconstruct_capture_matches_the_reconstruct_command(tiny_capture, tmp_path):
    from fringe3d.cli import main
    assert main(["reconstruct", str(tiny_capture), "-c", str(tiny_capture / "rig.json"),
                 "-o", str(tmp_path), "-q"]) == 0
    r = fringe3d.reconstruct_capture(tiny_capture, tiny_capture / "rig.json")
    np.testing.assert_array_equal(np.load(tmp_path / "points.npy"), r.points)


def test_the_cli_shows_fringe3d_warnings_as_warning_lines(capsys):
    from fringe3d.cli import show_warning
    from fringe3d.utils.warning_types import CalibrationWarning
    show_warning(CalibrationWarning("pose p: board not found"), CalibrationWarning, "x.py", 1)
    assert "warning: pose p: board not found" in capsys.readouterr().err
