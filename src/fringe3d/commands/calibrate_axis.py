"""``fringe3d calibrate-axis SCAN -c CALIB -o axis.json``: the turntable axis from a board."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import typer

from fringe3d.calibrate.boards import CircleBoard
from fringe3d.commands.output_options import overwrite_option
from fringe3d.multiview.axis import write_axis
from fringe3d.multiview.axis_session import calibrate_axis
from fringe3d.optics.rig import Rig
from fringe3d.utils.console import console, print_json, set_quiet
from fringe3d.utils.output_folder import open_output_file


def register(app: typer.Typer) -> None:
    @app.command("calibrate-axis")
    def calibrate_axis_command(
        scan: Path = typer.Argument(..., help="Multi-view capture of a circle board on the table (fringe3d capture "
                                    "--views N --stage ...: view-NN folders and poses.json with the stage angles)."),
        calibration: Path = typer.Option(..., "--calibration", "-c", help="Calibration (or rig.json) of the camera: "
                                         "its intrinsics and distortion; the axis is given in its frame."),
        output: Path = typer.Option(..., "-o", "--output", help="axis.json to write."),
        cols: int = typer.Option(9, help="Board circles per row."),
        rows: int = typer.Option(9, help="Board rows."),
        spacing: float = typer.Option(..., help="Circle spacing (mm)."),
        radius: float = typer.Option(None, help="Circle radius (mm); default spacing/4."),
        asymmetric: bool = typer.Option(False, help="OpenCV asymmetric circle grid."),
        overwrite: bool = overwrite_option(),
        json_: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="Print nothing but errors (and --json output)."),
    ) -> None:
        """Calibrate a turntable's axis from a circle board captured at several table angles.

        Each view's board pose (board -> camera, mm: circle centres in the white frame or the mean
        of the first pattern cycle, solvePnP with the calibrated camera) gives the axis (unit
        direction, camera frame), a point on it (mm) and the residuals: each pose predicted from
        view 0 turned by the stage's angle, RMS point distance (mm) and rotation (mrad); per view
        the turn the board shows beside the stage's. Capture with --stage-axis axis.json to turn
        stage angles into poses.

        Example: fringe3d calibrate-axis axis-scan -c calib.json --cols 7 --rows 6 --spacing 16 -o axis.json
        """
        set_quiet(quiet or json_)
        if not scan.is_dir():
            raise ValueError(f"{scan} is not a folder; expected a multi-view capture (fringe3d capture --views N)")
        rig = Rig.load(calibration)
        board = CircleBoard(cols=cols, rows=rows, spacing=spacing, radius=spacing / 4 if radius is None else radius,
                            asymmetric=asymmetric)
        with open_output_file(output, overwrite=overwrite, inputs=[scan, calibration]) as path:
            fit = calibrate_axis(scan, rig.camera, board)
            write_axis(path, fit, fit["views"])
        summary = {"output": str(output), "axis": fit["axis"], "point_mm": fit["point_mm"],
                   "rms_residual_mm": fit["rms_residual_mm"],
                   "rms_rotation_residual_mrad": fit["rms_rotation_residual_mrad"], "views": fit["views"],
                   "views_without_board": fit["views_without_board"]}
        if json_:
            print_json(summary)
            return
        if quiet:
            return
        a, p = np.round(fit["axis"], 5), np.round(fit["point_mm"], 3)
        console.print(f"axis {a.tolist()} through {p.tolist()} mm (camera frame); residual RMS "
                      f"{fit['rms_residual_mm']:.4f} mm, {fit['rms_rotation_residual_mrad']:.3f} mrad")
        for v in fit["views"]:
            console.print(f"  {v['name']}: stage {v['angle_deg']:g} deg, board turned {v['measured_angle_deg']:.3f} "
                          f"deg, residual {v['residual_mm']:.4f} mm")
        for m in fit["views_without_board"]:
            console.print(f"  board not found in {m}")
        console.print(f"wrote {output}")
