"""An experiment's result as files: its tables as CSV, its figures as PNG and SVG.

:func:`write_result` writes into a folder, for the result dict of an experiment's ``run``
(see :mod:`fringe3d.experiments`):

* ``table-N.csv``: table N, a header row of its columns then its rows, values exactly as in
  the JSON result (floats written with ``repr``, so they read back bit-exactly);
* ``table-N.png`` / ``table-N.svg``: table N's numeric columns plotted against its first column
  (lines when the first column is numeric, grouped bars when it names cases); when the
  dissertation gives figures, they are drawn beside ours in a second panel;
* ``dissertation.csv``: the dissertation's own figures (``quantity,value``), when it gives any;
* ``result.json``: the whole result, as the JSON summary holds it.
"""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import matplotlib

from fringe3d.utils.jsonfile import to_jsonable

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after choosing the non-interactive backend)


def _cell(v) -> str:
    """One CSV cell: floats by ``repr`` (round-trips exactly), None empty, the rest as text."""
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    return str(v)


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and v is not None and math.isfinite(v)


def write_csv(path: Path, columns: list, rows: list) -> None:
    """``columns`` then ``rows`` as a comma-separated file at ``path``."""
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow([str(c) for c in columns])
        for row in rows:
            w.writerow([_cell(v) for v in row])


def _numeric_columns(columns: list, rows: list) -> list[int]:
    """Indices (after the first) of the columns holding at least one finite number."""
    return [j for j in range(1, len(columns))
            if any(_is_number(r[j]) for r in rows if j < len(r))]


def _unit(column) -> str:
    """The unit a column name ends with in parentheses (``"sphere-fit RMS (um)"`` -> ``"um"``), else ``""``."""
    name = str(column).strip()
    return name[name.rindex("(") + 1:-1] if name.endswith(")") and "(" in name else ""


def _panels(columns: list, rows: list) -> list[list[int]]:
    """The numeric columns grouped by unit, one group per panel (one axis never mixes units)."""
    groups: dict[str, list[int]] = {}
    for j in _numeric_columns(columns, rows):
        groups.setdefault(_unit(columns[j]), []).append(j)
    return list(groups.values())


def _plot_panel(ax, columns: list, rows: list, cols: list[int]) -> None:
    """Columns ``cols`` of ``rows`` on ``ax`` against the first column: lines when it is numeric,
    grouped bars when it names cases."""
    xs = [r[0] for r in rows]
    numeric_x = all(_is_number(x) for x in xs)
    width = 0.8 / len(cols)
    for k, j in enumerate(cols):
        ys = [r[j] if j < len(r) and _is_number(r[j]) else math.nan for r in rows]
        if numeric_x:
            ax.plot(xs, ys, marker="o", label=str(columns[j]))
        else:
            ax.bar([i + (k - (len(cols) - 1) / 2) * width for i in range(len(rows))], ys, width,
                   label=str(columns[j]))
    if not numeric_x:
        ax.set_xticks(range(len(rows)), [_wrap(str(x), 18) for x in xs], fontsize=7)
    ax.set_xlabel(str(columns[0]))
    unit = _unit(columns[cols[0]])
    ax.set_ylabel(unit or "value")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)


def _wrap(text: str, width: int) -> str:
    words, lines, line = str(text).split(), [], ""
    for w in words:
        if line and len(line) + 1 + len(w) > width:
            lines.append(line)
            line = w
        else:
            line = f"{line} {w}".strip()
    return "\n".join([*lines, line])


def _draw_dissertation(ax, dissertation: dict) -> None:
    """The dissertation's figures as a two-column table panel (they are mostly ranges and ratios
    given in its text, not curves)."""
    ax.axis("off")
    ax.set_title("the dissertation's figures", fontsize=9)
    cells = [[_wrap(k, 34), _wrap(str(v), 20)] for k, v in dissertation.items()]
    tab = ax.table(cellText=cells, colLabels=["quantity", "dissertation"], loc="upper center",
                   cellLoc="left", colWidths=[0.64, 0.36])
    tab.auto_set_font_size(False)
    tab.set_fontsize(7)
    tab.scale(1.0, 2.2)


def write_result(folder: Path, result: dict) -> list[Path]:
    """Write ``result`` (an experiment's ``run`` dict) into ``folder``; return the paths written."""
    folder = Path(folder)
    result = to_jsonable(result)  # numpy scalars as Python numbers, exactly as --json prints them
    written: list[Path] = []
    for i, table in enumerate(result.get("tables", []), start=1):
        path = folder / f"table-{i}.csv"
        write_csv(path, table["columns"], table["rows"])
        written.append(path)
        written += _write_figure(folder / f"table-{i}", table, result.get("dissertation") or {})
    if result.get("dissertation"):
        path = folder / "dissertation.csv"
        write_csv(path, ["quantity", "value"], [[k, v] for k, v in result["dissertation"].items()])
        written.append(path)
    path = folder / "result.json"
    path.write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    written.append(path)
    return written


def _write_figure(stem: Path, table: dict, dissertation: dict) -> list[Path]:
    columns, rows = table["columns"], table["rows"]
    panels = _panels(columns, rows) if rows else []
    n = max(len(panels), 1) + (1 if dissertation else 0)
    ncols = min(n, 3)
    nrows = -(-n // ncols)
    fig, grid = plt.subplots(nrows, ncols, figsize=(5.2 * ncols, 4.2 * nrows + 0.4), squeeze=False)
    axes = list(grid.ravel())
    try:
        for ax, cols in zip(axes, panels):
            _plot_panel(ax, columns, rows, cols)
        if not panels:
            axes[0].axis("off")
            axes[0].text(0.5, 0.5, "(no numeric column)", ha="center")
        if dissertation:
            _draw_dissertation(axes[n - 1], dissertation)
        for ax in axes[n:]:
            ax.axis("off")
        fig.suptitle(_wrap(table["title"], 40 * ncols), fontsize=9)
        fig.tight_layout()
        out = [stem.with_suffix(".png"), stem.with_suffix(".svg")]
        fig.savefig(out[0], dpi=110)
        fig.savefig(out[1])
    finally:
        plt.close(fig)
    return out
