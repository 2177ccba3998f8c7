"""``fringe3d experiment NAME -o FOLDER``: every experiment's table as CSV equal to its ``--json``
rows, and its figures as readable, non-blank PNG (and SVG) beside the dissertation's figures
(issue 27, item 2)."""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from PIL import Image

from fringe3d import experiments
from fringe3d.cli import main

FAST = "optimal-angle"


def run_with_out(capsys, name: str, out) -> dict:
    assert main(["experiment", name, "--quick", "--json", "-o", str(out)]) == 0
    return json.loads(capsys.readouterr().out)


def assert_folder_holds_the_result(out, result: dict) -> None:
    for i, table in enumerate(result["tables"], start=1):
        with open(out / f"table-{i}.csv", newline="", encoding="utf-8") as f:
            header, *rows = list(csv.reader(f))
        assert header == [str(c) for c in table["columns"]]
        assert len(rows) == len(table["rows"])
        for got_row, want_row in zip(rows, table["rows"]):
            for got, want in zip(got_row, want_row, strict=True):
                if want is None:
                    assert got == ""
                elif isinstance(want, float):
                    assert float(got) == want or (np.isnan(want) and np.isnan(float(got)))
                else:
                    assert got == str(want)
        png = Image.open(out / f"table-{i}.png")
        pixels = np.asarray(png.convert("L"))
        assert min(png.size) >= 300 and pixels.std() > 5, "the figure has content, not a blank canvas"
        assert (out / f"table-{i}.svg").read_text(encoding="utf-8").lstrip().startswith("<?xml")
    if result.get("dissertation"):
        with open(out / "dissertation.csv", newline="", encoding="utf-8") as f:
            rows = [tuple(r) for r in list(csv.reader(f))[1:]]
        assert rows == [(k, str(v)) for k, v in result["dissertation"].items()]
    assert json.loads((out / "fringe3d.json").read_text())["complete"] is True


def test_experiment_out_folder_holds_csv_equal_to_the_json_and_its_figures(tmp_path, capsys):
    out = tmp_path / "figs"
    result = run_with_out(capsys, FAST, out)
    assert result["dissertation"], "this experiment's figures are drawn beside the dissertation's"
    assert_folder_holds_the_result(out, result)


def test_experiment_refuses_an_existing_out_folder_before_running(tmp_path, capsys):
    out = tmp_path / "figs"
    out.mkdir()
    (out / "mine.txt").write_text("keep")
    assert main(["experiment", FAST, "--quick", "-o", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert [p.name for p in out.iterdir()] == ["mine.txt"]


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(set(experiments.available()) - {FAST}, reverse=True))  # the
# experiments' own test files, on the other worker, take them in alphabetical order
def test_every_experiment_writes_its_tables_and_figures(tmp_path, capsys, monkeypatch, quick_experiment, name):
    # the experiment's computation is the session's shared quick run (its own test file checks it
    # against truth); everything the command does with the result is done here for real
    calls = []

    def shared_run(quick: bool, seed: int) -> dict:
        calls.append((quick, seed))
        return quick_experiment(name, seed)

    monkeypatch.setattr(experiments.get(name), "run", shared_run)
    out = tmp_path / name
    assert_folder_holds_the_result(out, run_with_out(capsys, name, out))
    assert calls == [(True, 0)]
