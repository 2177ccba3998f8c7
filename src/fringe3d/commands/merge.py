"""``fringe3d merge VIEWS... -o OUT``: register, fuse and mesh several views."""
from __future__ import annotations

from pathlib import Path

import typer

from fringe3d.commands.checks import check_choice, check_number, parse_stage_sigma
from fringe3d.commands.output_options import overwrite_option
from fringe3d.multiview.merge import MESH_METHODS, merge_views, write_merge
from fringe3d.multiview.poses import poses_for, read_stage_sigma
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
        stage_sigma: str = typer.Option(None, "--stage-sigma", help="The stage's stated 1-sigma pose error as "
                                        "ROT_MRAD,TRANS_MM (per axis; translation at the object centre): each pose "
                                        "is kept near its --poses value by that weight, so registration cannot "
                                        "drift where the data are blind (a ball bar's roll). Default: the poses "
                                        "file's stage.sigma_rotation_mrad / sigma_translation_mm when it states "
                                        "them; 'none' turns the prior off."),
        mesh: str = typer.Option("poisson", "--mesh", help="Mesh the fused cloud: poisson or none."),
        voxel: float = typer.Option(2.0, "--voxel", help="Registration sampling (mm); fusion uses half of it."),
        seed: int = typer.Option(0, "--seed", help="Seed of the RANSAC step."),
        overwrite: bool = overwrite_option(),
        json_: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="Print nothing but errors (and --json output)."),
    ) -> None:
        """Register several reconstructed views, fuse them into one cloud and mesh it.

        Writes OUT/fused.ply (mm, scalar_sigma_mm, scalar_views), OUT/mesh.ply, OUT/poses.json
        (registered poses) and OUT/merge.json (per-view residual RMS and pose 1-sigma: rotation
        mrad, translation of the view's object centre um, from the pose graph; null where nothing
        constrains a direction). With a stage prior (--stage-sigma, or the poses file's stated
        stage uncertainty) a pose's 1-sigma is at most the stage's.

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
        prior = stage_prior(stage_sigma, poses)
        with open_output(output, overwrite=overwrite, inputs=[*views, poses],
                         options={"mesh": mesh, "voxel": voxel, "seed": seed, "free_hand": free_hand,
                                  "stage_sigma": prior}) as out:
            merged = merge_views(vs, start, voxel=voxel, mesh=mesh, seed=seed, stage_sigma=prior)
            summary = out.final_paths(write_merge(out.path, merged))
        if json_:
            print_json(summary)
        elif not quiet:
            for v in summary["views"]:
                console.print(f"{v['name']}: residual RMS {_num(v['residual_rms_mm'])} mm, "
                              f"pose 1-sigma {_num(v['rotation_sigma_mrad'])} mrad / "
                              f"{_num(v['translation_sigma_um'])} um")
            if prior is not None:
                console.print(f"stage prior: {prior[0]:g} mrad, {prior[1]:g} mm (1-sigma per axis)")
            console.print(f"wrote {summary['files']}")


def stage_prior(text: str | None, poses: Path | None) -> tuple[float, float] | None:
    """The stage prior's ``(mrad, mm)`` from --stage-sigma, else from the poses file's ``stage``
    entry; None without poses, for 'none' or when the file states none (or zero)."""
    if text is not None and text.strip().lower() == "none":
        return None
    if poses is None:
        if text is not None:
            raise ValueError("--stage-sigma weighs the stage's poses: give --poses FILE (not --free-hand)")
        return None
    value = parse_stage_sigma(text, "--stage-sigma") if text is not None else read_stage_sigma(poses)
    if value is None or min(value) == 0:
        if text is not None:
            raise ValueError(f"--stage-sigma: both sigmas must be > 0 (a zero would pin the poses), got {text!r}")
        return None
    return value


def _num(x: float | None) -> str:
    return "n/a" if x is None else f"{x:.4g}"
