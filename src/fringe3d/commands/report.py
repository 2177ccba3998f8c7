"""``fringe3d report RESULTS``: one self-contained HTML page for a results folder."""
from __future__ import annotations

from pathlib import Path

import typer

from fringe3d.commands.output_options import overwrite_option
from fringe3d.report import write_report
from fringe3d.utils.output_folder import open_output_file
from fringe3d.utils.console import console, print_json, set_quiet


def register(app: typer.Typer) -> None:
    @app.command("report")
    def report(
        results: Path = typer.Argument(...,
                                       help="Results folder (with summary.json), e.g. the output of `fringe3d demo`."),
        output: Path = typer.Option(None, "-o", "--output", help="HTML file to write [default: RESULTS/report.html]."),
        overwrite: bool = overwrite_option(),
        json_: bool = typer.Option(False, "--json", help="Print the written path as JSON."),
        quiet: bool = typer.Option(False, "--quiet", "-q"),
    ) -> None:
        """Write one self-contained HTML page: calibration summary, residual plots, interactive 3D
        point clouds, error maps and the accuracy table. It needs no network to view.

        Example: fringe3d report demo-out -o demo-out/report.html
        """
        set_quiet(quiet)
        target = output if output is not None else results / "report.html"
        with open_output_file(target, overwrite=overwrite, inputs=[results / "summary.json"]):
            path = write_report(results, target)
        if json_:
            print_json({"report": str(path)})
        elif not quiet:
            console.print(f"wrote {path}")
