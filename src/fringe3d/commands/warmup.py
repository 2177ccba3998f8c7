"""``fringe3d warmup``: compile the measurement kernels now, not on the first real frame."""
from __future__ import annotations

import typer

from fringe3d.utils.console import console, info, make_table, print_json, set_quiet
from fringe3d.warmup import warm_up


def register(app: typer.Typer) -> None:
    @app.command("warmup")
    def warmup(
        json_: bool = typer.Option(False, "--json", help="Print the timings as one JSON object."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress output or tables."),
    ) -> None:
        """Compile the decode and reconstruction kernels ahead of the first frame.

        Runs the decode path and the fused 3-step path once on tiny simulated captures in a
        temporary folder (removed afterwards); numba keeps the compiled kernels on disk, so the
        first 3D frame of a real capture costs no compilation. `make demo` runs it after install.

        Example: fringe3d warmup
        """
        set_quiet(quiet or json_)
        rows = warm_up(announce=info)
        if json_:
            print_json({"paths": rows})
        elif not quiet:
            console.print(make_table("warmed paths", ["path", "seconds"], [[r["path"], r["seconds"]] for r in rows]))
