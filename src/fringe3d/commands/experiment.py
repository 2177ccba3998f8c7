"""``fringe3d experiment NAME``: run one virtual-lab experiment and print its tables."""
from __future__ import annotations

import time
from pathlib import Path

import typer

from fringe3d import experiments
from fringe3d.commands.output_options import overwrite_option
from fringe3d.experiments.figures import write_result
from fringe3d.utils.output_folder import open_output
from fringe3d.utils.console import console, make_table, print_json, set_quiet


def register(app: typer.Typer) -> None:
    @app.command("experiment")
    def experiment(
        name: str = typer.Argument(None, help="Experiment name; omit (or use --list) to list them."),
        list_: bool = typer.Option(False, "--list", help="List the experiments and exit."),
        quick: bool = typer.Option(False, "--quick", help="Smaller, faster variant (used by the tests)."),
        seed: int = typer.Option(0, help="Random seed: the same seed gives the same figures."),
        json_: bool = typer.Option(False, "--json", help="Print one JSON object instead of tables."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bars."),
        out: Path = typer.Option(None, "-o", "--output", help=(
            "Also write the result into this folder: each table as CSV (table-N.csv), its figure "
            "as PNG and SVG beside the dissertation's figures (table-N.png/.svg), dissertation.csv "
            "and result.json.")),
        overwrite: bool = overwrite_option(),
    ) -> None:
        """Reproduce one of the dissertation's results in simulation, beside its own figure.

        Example: fringe3d experiment unwrap-noise --quick -o unwrap-noise-figures
        """
        set_quiet(quiet or json_)
        if list_ or not name:
            rows = [[n, getattr(m, "SUMMARY", "")] for n, m in experiments.available().items()]
            if json_:
                print_json({"experiments": [{"name": n, "summary": d} for n, d in rows]})
                return
            console.print(make_table("experiments", ["name", "what it reproduces"], rows))
            return
        mod = experiments.get(name)
        if out is None:
            result = _run(mod, name, quick, seed)
        else:  # the folder is claimed (or refused) before the experiment runs
            with open_output(out, overwrite=overwrite, options={"experiment": name, "seed": seed, "quick": quick}) as o:
                result = _run(mod, name, quick, seed)
                write_result(o.path, result)
        if json_:
            print_json(result)
            return
        for tab in result.get("tables", []):
            console.print(make_table(tab["title"], tab["columns"], tab["rows"]))
        if result.get("dissertation"):
            console.print("[bold]dissertation:[/] " + "; ".join(f"{k}: {v}" for k, v in result["dissertation"].items()))
        for k, v in result.get("goals", {}).items():
            console.print(f"goal {k}: {'[green]met[/]' if v else '[red]not met[/]'}")
        for note in result.get("notes", []):
            console.print(f"note: {note}")
        console.print(f"({result['seconds']} s, seed {seed})")


def _run(mod, name: str, quick: bool, seed: int) -> dict:
    """Run one experiment; its result dict with the run's name, seconds, seed and variant added."""
    t0 = time.perf_counter()
    result = mod.run(quick=quick, seed=seed)
    result.setdefault("experiment", name)
    result["seconds"] = round(time.perf_counter() - t0, 2)
    result["seed"] = seed
    result["quick"] = quick
    return result
