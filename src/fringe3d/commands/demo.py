"""``fringe3d demo``: the main job, end to end on the built-in virtual rig."""
from __future__ import annotations

from pathlib import Path

import typer

from fringe3d import experiments
from fringe3d.demo import run_demo
from fringe3d.commands.output_options import overwrite_option
from fringe3d.utils.output_folder import open_output
from fringe3d.utils.console import console, info, make_table, print_json, set_quiet


def register(app: typer.Typer) -> None:
    @app.command("demo")
    def demo(
        output: Path = typer.Option(Path("demo-out"), "-o", "--output", help="Results folder to write."),
        profile: str = typer.Option("default", help="'default' (macro rig, 1280x1024) or 'tiny' (seconds)."),
        seed: int = typer.Option(0, help="Random seed (board poses, noise): same seed, same figures."),
        full: bool = typer.Option(False, "--full", help="Also run the falling-ball and flapping-wing sequences."),
        overwrite: bool = overwrite_option(),
        json_: bool = typer.Option(False, "--json", help="Print the summary as one JSON object."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress output or tables."),
    ) -> None:
        """Render a calibration session, calibrate, render a measurement scene (sculpture, sphere,
        ball bar), reconstruct, evaluate against ground truth, and write calibration JSON, PLY
        clouds, PNG figures and report.html.

        Example: fringe3d demo -o demo-out && open demo-out/report.html
        """
        set_quiet(quiet or json_)
        sequences = (lambda sd: experiments.run_sequences(sd, announce=info)) if full else None
        with open_output(output, overwrite=overwrite, options={"profile": profile, "seed": seed, "full": full}) as o:
            s = o.final_paths(run_demo(o.path, profile=profile, seed=seed, sequences=sequences, announce=info))
        if json_:
            print_json(s)
            return
        if quiet:
            return
        cal = s["calibration"]["figures"]
        console.print(make_table("calibration", ["figure", "value"], [[k, v] for k, v in cal.items()]))
        console.print(make_table("accuracy (against the simulator's truth)",
                                 ["quantity", "value", "unit", "dissertation"],
                                 [[a["quantity"], a["value"], a["unit"], a.get("dissertation", "")]
                                  for a in s["accuracy"]]))
        console.print(make_table("time per stage", ["stage", "seconds"],
                                 [[r["name"], r["seconds"]] for r in s["stages"]]))
        for name, r in s.get("sequences", {}).items():
            console.print(f"{name}: " + ", ".join(f"{k} {'met' if v else 'NOT met'}" for k, v in r["goals"].items()))
        console.print(f"wrote {output}/report.html ({s['seconds_total']} s)")
