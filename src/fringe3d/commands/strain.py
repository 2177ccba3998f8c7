"""``fringe3d strain``: track a wing through a 3D sequence and map its bending strain (ch. 6).

SEQUENCE (read by :func:`fringe3d.io.point_sequence.read_point_sequence`) is one of
* a folder of per-frame point maps ``points_00000.npy`` … ((H, W, 3) float, mm, NaN invalid),
  optionally with textures ``texture_00000.npy`` / ``.png`` (for ``--anchors auto``);
* a single ``.npy`` / ``.npz`` holding ``points`` (F, H, W, 3) (and optionally ``texture``);
* a zarr store (folder) with arrays ``points`` (F, H, W, 3) and optionally ``texture`` (F, H, W)
  and ``done`` (F,) completion flags (:class:`fringe3d.io.store.PointMapStore`), or a folder
  holding such a ``points.zarr``.

Outputs in OUT (each written atomically, and only after every input check has passed):
``strain.csv`` (all frames, wings and points; units in the header), ``vtk/frame_00000.vtu`` (one
binary VTK XML grid per frame: the tracked points' triangles and their strain) with
``strain.pvd`` (the time series for ParaView), ``arrays/wing_0/*.npy`` (the per-point results as
(F, N, ...) arrays: uv, xyz, E, principal, dominant, residual, ok), ``maps/strain_00000.png``
(dominant strain maps with a colour bar),
``strain.gif`` (animation) and ``summary.json``.

Frames are streamed: each one's rows, ``.vtu`` and array rows are written before the next few
frames are read, so memory does not grow with the sequence. ``--threads N`` processes N frames
at once on threads and writes the same files as one worker. ``--processes N`` (a local
cluster of N worker processes) or ``--scheduler tcp://HOST:8786`` (an existing cluster, whose
workers read SEQUENCE at the same path) run each frame as a dask.distributed task
(:mod:`fringe3d.cluster.strain_frames`); this process still writes every file, the same bytes.
"""
from __future__ import annotations

from pathlib import Path

import typer

from fringe3d.analyze.anchors import parse_anchors
from fringe3d.analyze.strain import TrackingSettings
from fringe3d.analyze.wing_strain import StrainSettings, run_strain
from fringe3d.commands.checks import check_number
from fringe3d.io.point_sequence import read_point_sequence
from fringe3d.cluster.engine import close, connect
from fringe3d.cluster.strain_frames import frames_on_dask
from fringe3d.commands.deprecated import AliasCommand
from fringe3d.commands.vocabulary import processes_option, threads_option
from fringe3d.commands.output_options import overwrite_option
from fringe3d.utils.output_folder import open_output
from fringe3d.utils.console import console, make_table, print_json, set_quiet


def register(app: typer.Typer) -> None:
    @app.command("strain", cls=AliasCommand)
    def strain(
        sequence: Path = typer.Argument(..., help="Folder of points_*.npy, a .npy/.npz (F,H,W,3) or a zarr store."),
        anchors: str = typer.Option(..., "--anchors", help="'u1,v1,u2,v2' pixel anchors (';' between wings) "
                                                           "or 'auto' (dark dots in the texture)."),
        out: Path = typer.Option(..., "-o", "--output", help="Output folder."),
        thickness: float = typer.Option(0.1, help="Membrane thickness h (mm) for E = (h/2)·κ (Eq. 6.11)."),
        window: int = typer.Option(11, help="Quadratic-fit neighbourhood (odd, pixels)."),
        step: int = typer.Option(4, help="Track every STEP-th pixel of the reference frame."),
        wings: int = typer.Option(1, help="Number of wings (anchor pairs) for --anchors auto."),
        radius: int = typer.Option(3, help="Geodesic marching window half-size (3 = the dissertation's 7×7)."),
        reference: int = typer.Option(0, help="Index of the undeformed reference frame."),
        fill_dots: int = typer.Option(8, "--fill-dots", help="Fill unreconstructed anchor-dot holes up to this "
                                                             "radius (px) from the surrounding surface; 0 = off."),
        frame_rate: float = typer.Option(None, "--frame-rate", help="Rate of the 3D frames (Hz): the PVD time "
                                                                    "steps in seconds (default: frame numbers)."),
        no_figures: bool = typer.Option(False, "--no-figures", help="Skip the PNG maps and the GIF."),
        workers: int = threads_option(1, "3D frames processed at once on N threads; the output is the same "
                                         "for any number."),
        dask_workers: int = processes_option("Run the frames on a local Dask cluster of N worker processes "
                                             "(fringe3d[dask]); the output is the same."),
        scheduler: str = typer.Option(None, "--scheduler",
                                      help="Run the frames on an existing dask.distributed scheduler, e.g. "
                                           "tcp://HOST:8786 (its workers must read SEQUENCE at the same path)."),
        overwrite: bool = overwrite_option(),
        json_: bool = typer.Option(False, "--json", help="Print a JSON summary."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bars."),
    ) -> None:
        """Track every point of an inextensible wing by geodesic distances (Eq. 6.9) and map its
        Kirchhoff–Love bending strain (Eq. 6.10–6.21): CSV, VTU + PVD, PNG maps, GIF.

        Example: fringe3d strain wing-points/ --anchors 120,80,300,82 -o wing-strain --json
        """
        set_quiet(quiet or json_)
        options = {"anchors": anchors, "thickness": thickness, "window": window, "step": step, "wings": wings,
                   "radius": radius, "reference": reference, "figures": not no_figures, "fill_dots": fill_dots,
                   "frame_rate": frame_rate}
        if frame_rate is not None and not frame_rate > 0:
            raise ValueError(f"--frame-rate must be > 0 Hz; got {frame_rate}")
        check_schedulers(workers, dask_workers, scheduler)
        check_number(thickness, "--thickness", positive=True)
        parse_anchors(anchors)  # bad anchors, then a missing, empty or damaged sequence, fail before any output
        read_point_sequence(sequence)
        client = None  # connected before anything is written: an unreachable scheduler leaves no folder
        if dask_workers is not None or scheduler is not None:
            client = connect(scheduler, dask_workers)
        try:
            with open_output(out, overwrite=overwrite, inputs=[sequence], options=options) as o:
                frames = frames_on_dask(client) if client is not None else None
                settings = StrainSettings(thickness, step, wings, reference,
                                          TrackingSettings(window=window, radius=radius, fill_dots=fill_dots))
                summary = o.final_paths(run_strain(sequence, anchors, o.path, settings, figures=not no_figures,
                                                   workers=workers, frames=frames, frame_rate=frame_rate))
        finally:
            if client is not None:
                close(client, own_cluster=scheduler is None)
        if json_:
            print_json(summary)
        elif not quiet:
            console.print(make_table("strain", ["field", "value"], [[k, str(v)] for k, v in summary.items()]))


def check_schedulers(workers: int, dask_workers: int | None, scheduler: str | None) -> None:
    """ValueError unless at most one frame scheduler is asked for: threads (``--threads`` > 1), a
    local Dask cluster (``--processes``) or an existing one (``--scheduler``)."""
    if dask_workers is not None and dask_workers < 1:
        raise ValueError(f"--processes must be at least 1 worker process, got {dask_workers}")
    if dask_workers is not None and scheduler is not None:
        raise ValueError("give either --processes (a local cluster) or --scheduler (an existing one), not both")
    if workers != 1 and (dask_workers is not None or scheduler is not None):
        raise ValueError(f"--threads {workers} runs threads in this process; with --processes or --scheduler "
                         "the Dask workers do the frames (drop --threads)")
