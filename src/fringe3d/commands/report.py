"""``fringe3d report RESULTS``: one self-contained HTML page for a results folder."""
from __future__ import annotations

from pathlib import Path

import typer

from fringe3d.commands.output_options import overwrite_option
from fringe3d.report import write_report
from fringe3d.report.html import default_output
from fringe3d.utils.output_folder import open_output_file
from fringe3d.utils.console import console, print_json, set_quiet


def register(app: typer.Typer) -> None:
    @app.command("report")
    def report(
        results: Path = typer.Argument(...,
                                       help="Results folder of any command (demo, decode, reconstruct + evaluate, "
                                       "strain, merge) or a calibration JSON."),
        output: Path = typer.Option(None, "-o", "--output", help="HTML file to write [default: RESULTS/report.html]."),
        overwrite: bool = overwrite_option(),
        json_: bool = typer.Option(False, "--json", help="Print the written path as JSON."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="Print nothing but errors (and --json output)."),
    ) -> None:
        """Write one self-contained HTML page from what RESULTS holds: provenance (fringe3d.json),
        calibration parameters, measurement figures with their definitions (evaluate.json), error
        and quality maps with colour bars and an interactive 3D view of the points. A merge
        folder gets its fused model (coloured by the number of views or sigma, and the mesh), a
        per-view table (residual RMS, pose 1-sigma, points, overlap) and its coverage, with the
        figures against the truth when evaluate wrote them. It needs no network to view.

        Example: fringe3d report demo-out -o demo-out/report.html
        """
        set_quiet(quiet or json_)
        target = output if output is not None else default_output(results)
        read = [results] if results.is_file() else sorted(results.glob("*.json"))
        with open_output_file(target, overwrite=overwrite, inputs=read):
            path = write_report(results, target)
        if json_:
            print_json({"report": str(path)})
        elif not quiet:
            console.print(f"wrote {path}")
