"""The virtual lab: each dissertation result reproduced in simulation.

Every experiment is a module here defining

* ``NAME``: the command-line name (e.g. ``"unwrap-noise"``),
* ``SUMMARY``: one line for ``fringe3d experiment --list``,
* ``run(quick: bool = False, seed: int = 0) -> dict``: does the work (seeded, repeatable)
  and returns a JSON-friendly dict with at least ``"tables"``: a list of
  ``{"title": str, "columns": [...], "rows": [[...], ...]}`` and ``"dissertation"``: the
  dissertation's own figure(s) for comparison, and ``"goals"``: ``{name: bool}``.

``fringe3d experiment NAME`` prints the tables; ``fringe3d experiment NAME --json`` prints the dict;
``fringe3d experiment NAME -o FOLDER`` also writes them as CSV with PNG/SVG figures
(:mod:`fringe3d.experiments.figures`).
"""
from __future__ import annotations

import importlib
import time
from collections.abc import Callable
from types import ModuleType


#: The experiment modules (``fringe3d.experiments.<name>``), in listing order. Each is imported
#: when the experiments are listed or one is run, so that ``import fringe3d.experiments`` stays
#: cheap; a module that fails to import fails loudly.
MODULES = ("binary_defocus", "defocus_calibration", "falling_balls", "flapping_wing", "motion_error",
           "optimal_angle", "single_shot", "telecentric", "unwrap_noise")


def available() -> dict[str, ModuleType]:
    """Map experiment names to their modules, sorted by name."""
    out: dict[str, ModuleType] = {}
    for name in MODULES:
        m = importlib.import_module(f"{__name__}.{name}")
        out[m.NAME] = m
    return dict(sorted(out.items()))


def get(name: str) -> ModuleType:
    exps = available()
    if name not in exps:
        raise ValueError(f"unknown experiment {name!r}; available: {', '.join(exps) or '(none)'}")
    return exps[name]


def run_sequences(seed: int, announce: Callable[[str], None] | None = None) -> dict:
    """The falling-ball and flapping-wing experiments (full variants, ~2.5 min), as
    ``fringe3d demo --full`` reports them: ``{name: {"goals", "tables", "seconds"}}``.
    ``announce(text)`` is called before each experiment (the CLI prints it)."""
    out = {}
    for name in ("falling-balls", "flapping-wing"):
        if announce is not None:
            announce(f"[bold]{name}[/] …")
        t0 = time.perf_counter()
        r = get(name).run(quick=False, seed=seed)
        out[name] = {"goals": r.get("goals", {}), "tables": r.get("tables", []),
                     "seconds": round(time.perf_counter() - t0, 1)}
    return out
