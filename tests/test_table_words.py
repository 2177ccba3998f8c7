"""Printed tables read as figures with units and are never truncated (issue 27, item 4)."""
from __future__ import annotations

import io

from rich.console import Console

from fringe3d.commands.evaluate import figure_unit
from fringe3d.utils.console import make_table


def test_a_table_wider_than_the_terminal_wraps_and_keeps_every_character():
    long_name = "direct_triangulation_with_a_long_name"
    value = 0.13189315795898438
    out = io.StringIO()
    Console(file=out, width=40, color_system=None).print(
        make_table("t", ["figure", "value", "a wide column header"], [[long_name, value, "x" * 30]]))
    text = out.getvalue()
    assert "…" not in text
    body = [line.split("│")[1:-1] for line in text.splitlines() if line.count("│") == 4]
    columns = ["".join(cells[j].strip() for cells in body) for j in range(3)]
    assert long_name in columns[0] and "x" * 30 in columns[2]
    assert columns[1] == "0.1319"  # four significant digits, not the raw float


def test_evaluate_names_a_unit_only_for_lengths():
    assert figure_unit("rms_mm", 0.13189315795898438) == "mm"
    assert figure_unit("diameter", 100.0) == "mm"
    assert figure_unit("n_points", 500) == ""
    assert figure_unit("object_id", None) == ""
    assert figure_unit("share_over_1mm", 0.02) == ""
    assert figure_unit("coverage", 0.9) == ""
