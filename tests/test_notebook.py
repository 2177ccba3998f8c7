"""examples/capture_to_evaluated_cloud.ipynb runs top to bottom (simulate, reconstruct, evaluate)."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

import fringe3d

NOTEBOOK = Path(__file__).resolve().parents[1] / "examples" / "capture_to_evaluated_cloud.ipynb"


def test_capture_to_evaluated_cloud_notebook_runs(tmp_path, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    src = str(Path(fringe3d.__file__).resolve().parents[1])  # the kernel imports this fringe3d
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(p for p in (src, os.environ.get("PYTHONPATH")) if p))
    nb = nbformat.read(NOTEBOOK, as_version=4)
    nbclient.NotebookClient(nb, timeout=120, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    text = "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []))
    assert "error vs truth: RMS" in text and "sphere: diameter" in text
    assert "points; point data:" in text or "fringe3d[pyvista]" in text
