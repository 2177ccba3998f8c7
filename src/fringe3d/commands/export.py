"""``fringe3d export INPUT -o OUT.ext``: a measurement in the file format other tools read."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import typer

from fringe3d.commands.output_options import overwrite_option
from fringe3d.io.export import MESH_SUFFIXES, POINT_SUFFIXES, check_suffix, write_mesh, write_points
from fringe3d.io.measurement_source import read_measurement
from fringe3d.utils.console import console, print_json, set_quiet
from fringe3d.utils.output_folder import open_output_file

#: Suffixes written as a triangle mesh (``.ply`` is written as a point cloud unless ``--mesh``).
MESH_ONLY = tuple(s for s in MESH_SUFFIXES if s not in POINT_SUFFIXES)


def register(app: typer.Typer) -> None:
    @app.command("export")
    def export(
        source: Path = typer.Argument(..., metavar="INPUT",
                                      help="A reconstruct output folder (points.npy, texture.tif, sigma_z.tif), "
                                      "a sequence's points.zarr (with --frame) or a .ply point cloud / mesh."),
        output: Path = typer.Option(..., "-o", "--output",
                                    help="File to write; its suffix chooses the format: points "
                                    f"{', '.join(POINT_SUFFIXES)}; meshes {', '.join(MESH_SUFFIXES)}."),
        frame: int = typer.Option(None, "--frame", help="INPUT is a point store (points.zarr): the 3D frame to "
                                  "export (0-based)."),
        mesh: bool = typer.Option(False, "--mesh", help="Write a .ply as a triangle mesh (the pixel grid's "
                                  "triangles, or the input PLY's faces) instead of a point cloud."),
        overwrite: bool = overwrite_option(),
        json_: bool = typer.Option(False, "--json", help="Print the written path and counts as JSON."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="Print nothing but errors (and --json output)."),
    ) -> None:
        """Write a measurement in the format other tools read (PLY, VTP, E57, LAS/LAZ, MAT, STL, OBJ, GLB).

        Points keep their colours and scalar fields (sigma_z_mm, roughness_mm) where the format
        can hold them (VTP: for ParaView and PyVista, whose PLY reader drops scalar fields); units
        are mm except E57 and GLB, whose formats fix the metre (see docs/file-formats.md). STL,
        OBJ and GLB are meshes: the pixel grid's triangles of a reconstruct folder, or the faces
        of a PLY mesh.

        Example: fringe3d export out -o out/points.e57
        """
        set_quiet(quiet or json_)
        as_mesh = mesh or output.suffix.lower() in MESH_ONLY
        check_suffix(output, MESH_SUFFIXES if as_mesh else POINT_SUFFIXES, "a mesh" if as_mesh else "points")
        inputs = [source] if source.is_file() else sorted(source.glob("*"))
        try:
            path, counts = _export(source, output, frame, as_mesh, overwrite, inputs)
        except ImportError as e:  # an optional library of the exchange extra is missing
            raise ValueError(str(e)) from None
        if json_:
            print_json({"output": str(path), **counts})
        elif not quiet:
            console.print(f"wrote {path}")


def _export(source: Path, output: Path, frame: int | None, as_mesh: bool, overwrite: bool, inputs) -> tuple:
    """Read ``source`` and write ``output``; returns the path written and its counts."""
    with open_output_file(output, overwrite=overwrite, inputs=inputs):
        m = read_measurement(source, frame)
        if as_mesh:
            V, F, C = m.mesh(output)
            path = write_mesh(output, V, F, colors=C)
            counts = {"vertices": len(V), "faces": len(F)}
        else:
            path = write_points(output, m.points, m.attributes, colors=m.colors)
            counts = {"points": int(np.all(np.isfinite(m.points), axis=-1).sum())}
    return path, counts
