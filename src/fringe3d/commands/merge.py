"""``fringe3d merge VIEWS... -o OUT``: register, fuse and mesh several views."""
from __future__ import annotations

from pathlib import Path

import typer

from fringe3d.commands.checks import check_choice, check_number
from fringe3d.commands.output_options import overwrite_option
from fringe3d.multiview.merge import MESH_METHODS, merge_views, write_merge
from fringe3d.multiview.poses import poses_for
from fringe3d.multiview.views import read_view
from fringe3d.utils.console import console, print_json, set_quiet
from fringe3d.utils.output_folder import open_output


def register(app: typer.Typer) -> None:
    @app.command("merge")
    def merge(
        views: list[Path] = typer.Argument(..., help="Reconstruct output folders (points.npy, optional sigma_z.tif)."),
        output: Path = typer.Option(..., "-o", "--output", help="Output folder."),
        poses: Path = typer.Option(None, "--poses", help="poses.json: one 4x4 view -> model matrix (mm) per view "
                                   "name (the folder's name); the start of registration."),
        free_hand: bool = typer.Option(False, "--free-hand", help="No poses: start from global feature "
                                       "registration (FPFH + RANSAC) between consecutive views."),
        mesh: str = typer.Option("poisson", "--mesh", help="Mesh the fused cloud: poisson or none."),
        voxel: float = typer.Option(2.0, "--voxel", help="Registration sampling (mm); fusion uses half of it."),
        seed: int = typer.Option(0, "--seed", help="Seed of the RANSAC step."),
        overwrite: bool = overwrite_option(),
        json_: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="Print nothing but errors (and --json output)."),
    ) -> None:
        """Register several reconstructed views, fuse them into one cloud and mesh it.

        Writes OUT/fused.ply (mm, scalar_sigma_mm, scalar_views), OUT/mesh.ply, OUT/poses.json
        (registered poses) and OUT/merge.json (per-view residual RMS and pose uncertainty).

        Example: fringe3d merge scan/view-00 scan/view-01 scan/view-02 --poses scan/poses.json -o merged
        """
        set_quiet(quiet or json_)
        check_choice(mesh, "--mesh", MESH_METHODS)
        check_number(voxel, "--voxel", positive=True)
        if (poses is None) == (not free_hand):
            raise ValueError("give exactly one of --poses FILE or --free-hand")
        if len(views) < 2:
            raise ValueError(f"merge needs at least 2 views, got {len(views)}")
        vs = [read_view(v) for v in views]
        names = [v.name for v in vs]
        if len(set(names)) != len(names):
            raise ValueError(f"view folder names must differ (poses are looked up by name): {', '.join(names)}")
        start = poses_for(poses, names) if poses is not None else None
        with open_output(output, overwrite=overwrite, inputs=[*views, poses],
                         options={"mesh": mesh, "voxel": voxel, "seed": seed, "free_hand": free_hand}) as out:
            merged = merge_views(vs, start, voxel=voxel, mesh=mesh, seed=seed)
            summary = out.final_paths(write_merge(out.path, merged))
        if json_:
            print_json(summary)
        elif not quiet:
            for v in summary["views"]:
                console.print(f"{v['name']}: residual RMS {_num(v['residual_rms_mm'])} mm, "
                              f"pose 1-sigma {_num(v['rotation_sigma_mrad'])} mrad / "
                              f"{_num(v['translation_sigma_um'])} um")
            console.print(f"wrote {summary['files']}")


def _num(x: float | None) -> str:
    return "n/a" if x is None else f"{x:.4g}"
