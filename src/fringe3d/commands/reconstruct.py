"""``fringe3d reconstruct CAPTURE --calibration FILE -o OUT``: absolute 3D point maps."""
from __future__ import annotations

import json
import time
from pathlib import Path

import typer

from fringe3d.commands.deprecated import AliasCommand
from fringe3d.decode import DecodeOptions
from fringe3d.cluster.engine import close, connect, dask_executor, reconstruct_capture_on_dask
from fringe3d.commands.checks import check_choice, check_number
from fringe3d.commands.vocabulary import method_option, processes_option
from fringe3d.commands.output_options import allow_empty_option, overwrite_option
from fringe3d.commands.plan_errors import in_flag_words
from fringe3d.commands.compensate_options import (check_plans_for, compensate_option, resolve_compensation,
                                                      response_option)
from fringe3d.commands.quality_options import edge_margin_option, edge_mask_option
from fringe3d.decode.plan_checks import check_plans
from fringe3d.gpu import BACKENDS, cuda_module
from fringe3d.decode.bracket import fuse_bracket
from fringe3d.io.capture import list_frame_files, open_frames, read_capture, read_meta
from fringe3d.io.export import write_points
from fringe3d.io.measurement_source import measurement_attributes
from fringe3d.io.store import CODECS
from fringe3d.optics import Rig
from fringe3d.optics.rig_geometry import RigGeometry
from fringe3d.patterns.manifest import MANIFEST_NAME
from fringe3d.patterns.method_registry import relative_methods
from fringe3d.utils.output_folder import open_output
from fringe3d.pipeline import CycleSettings, check_sizes, reconstruct_cycle, reference_z_min
from fringe3d.reconstruct.depth import EmptyMaskError
from fringe3d.io.capture_frames import CaptureFolder
from fringe3d.reconstruct.frame import reconstruction_plans
from fringe3d.reconstruct.sequence import reconstruct_sequence
from fringe3d.reconstruct.settings import DecodeSettings, OutputSettings, RunSettings
from fringe3d.reconstruct.why_empty import why_no_points
from fringe3d.utils.console import (
    console,
    info,
    make_table,
    print_json,
    set_quiet,
    to_jsonable,
)
from fringe3d.utils.jsonfile import write_json

#: Units of reconstruct.json's fields.
RECONSTRUCT_UNITS = {"depth_min": "mm", "depth_max": "mm", "z_min": "mm", "valid_share": "1",
                     "shape": "px (rows, columns)", "seconds": "s", "points": "mm (camera frame)"}


#: ``--format`` words: point formats beside the PLY (``--ply``).
EXTRA_FORMATS = ("e57", "las", "laz", "mat")


def _sequence(out: Path, capture: CaptureFolder, ps, rig: RigGeometry,
              settings: tuple[DecodeSettings, OutputSettings, RunSettings], client, chunk: int) -> dict:
    """The sequence branch: in this process (reusing the maps of ``rig``, the rig's geometry that the
    checks filled), or on Dask when a ``client`` is given (the rig alone travels)."""
    if client is not None:
        return reconstruct_capture_on_dask(capture, ps, rig.rig, out, dask_executor(client, chunk), *settings)
    return reconstruct_sequence(capture, ps, rig, out, *settings)


def register(app: typer.Typer) -> None:
    @app.command("reconstruct", cls=AliasCommand)
    def reconstruct_cmd(
        capture: Path = typer.Argument(..., help="Capture folder: manifest.json + frames/ (+ capture.json)."),
        calibration: Path = typer.Option(..., "--calibration", "-c",
                                         help="Calibration JSON (with a 'rig' entry) or rig JSON."),
        out: Path = typer.Option(..., "-o", "--output", help="Output folder."),
        method: str = method_option("Unwrapping method for every direction (default: the manifest's plans)."),
        z_min: float = typer.Option(None, "--z-min", help="Nearest depth of the scene (mm), for geometric methods."),
        z_min_from: Path = typer.Option(None, "--z-min-from",
                                        help="Propose z_min from a reference measurement (points.npy or a reconstruct "
                                             "output folder): its nearest depth minus --z-margin."),
        z_margin: float = typer.Option(5.0, "--z-margin", help="Margin (mm) below the reference's nearest depth."),
        ply: bool = typer.Option(False, "--ply", help="Also write PLY point clouds (coloured by the texture; "
                                 "one cycle: points.vtp beside, for ParaView)."),
        mesh: bool = typer.Option(False, "--mesh", help="One cycle: points.ply also holds the pixel grid's triangles "
                                  "(implies --ply)."),
        formats: list[str] = typer.Option([], "--format",
                                          help="One cycle: also write points.<FORMAT> (e57, las, laz or mat; "
                                               "repeatable; ply is --ply; other formats: fringe3d export)."),
        store: bool = typer.Option(True, "--store/--no-store", help="Sequences: write the zarr point store."),
        store_layout: str = typer.Option("auto", "--store-layout",
                                         help="Sequences: auto (one depth per pixel along the camera ray where that "
                                              "gives the points exactly, else xyz), xyz or ray_depth."),
        store_quality: bool = typer.Option(True, "--store-quality/--no-store-quality",
                                           help="Sequences: also store each 3D frame's quality map and sigma_z."),
        store_codec: str = typer.Option("lz4", "--store-codec",
                                        help="Sequences: the point store's compression: lz4 (about half the bytes), "
                                             "zstd (a little smaller, slower) or none (twice the bytes, no "
                                             "compression work; faster only where the disk keeps up)."),
        window: int = typer.Option(None, "--window",
                                   help="Sequences: a 3D frame every N captured frames (sliding window) instead of "
                                        "one per pattern cycle."),
        triangulation: str = typer.Option("auto", "--triangulation",
                                          help="auto, fast (closed form) or lsq (Eq. 2.37)."),
        min_modulation: float = typer.Option(None, "--min-modulation",
                                             help="Modulation threshold, camera counts (default 2% of full scale)."),
        max_cycles: int = typer.Option(None, "--max-cycles", help="Use only the first N pattern cycles."),
        workers: int = processes_option("Sequences: run on a local Dask cluster of N worker processes "
                                        "(fringe3d[dask]); default: in this process."),
        scheduler: str = typer.Option(None, "--scheduler",
                                      help="Sequences: run on an existing dask.distributed scheduler, e.g. "
                                           "tcp://HOST:8786 (its workers must read the capture at the same path)."),
        chunk: int = typer.Option(8, "--chunk", help="Sequences on Dask: 3D frames per task."),
        device: str = typer.Option("cpu", "--device",
                                   help="Where the per-pixel kernels run: cpu, or cuda (an NVIDIA GPU with "
                                        "fringe3d[cuda]; docs/gpu.md). On Dask, cuda tasks go to workers "
                                        "started with --resources GPU=1."),
        edge_mask: bool = edge_mask_option(),
        edge_margin: float = edge_margin_option(),
        compensate: str = compensate_option(),
        response: Path = response_option(),
        overwrite: bool = overwrite_option(),
        allow_empty: bool = allow_empty_option(),
        allow_relative: bool = typer.Option(False, "--allow-relative",
                                            help=f"Triangulate a wrapped or relative phase (method "
                                                 f"{' or '.join(relative_methods())}) "
                                                 "anyway: its 3D is off by an unknown number of fringe periods in "
                                                 "depth; reconstruct.json marks it (relative_phase) and evaluate "
                                                 "says so. Default: refuse, naming the absolute methods."),
        json_: bool = typer.Option(False, "--json", help="Print one JSON summary."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bars or tables."),
    ) -> None:
        """Reconstruct absolute 3D point maps from a capture and a calibration.

        One pattern cycle: OUT/points.npy ((H, W, 3) float32 mm, NaN invalid), OUT/depth.tif,
        OUT/texture.tif (+ OUT/points.ply with --ply: normals, colour, the scalar fields sigma_z_mm and
        roughness_mm, units and provenance in the header; --mesh adds the grid's triangles; and
        OUT/points.vtp, the same points and fields for ParaView and PyVista) and OUT/reconstruct.json. A sequence:
        OUT/points.zarr (one point map per cycle or window, with its quality map and sigma_z; resumable) and/or
        OUT/ply/.

        A direction unwrapped with none (wrapped phase) or spatial (relative phase) is refused before
        anything is written, naming the absolute methods the manifest can feed (--allow-relative
        writes it anyway, marked in reconstruct.json).

        Example: fringe3d reconstruct sphere-capture --calibration calib.json -o sphere-3d --ply
        """
        set_quiet(quiet or json_)
        t0 = time.perf_counter()
        check_number(min_modulation, "--min-modulation", minimum=0)
        check_number(z_min, "--z-min")
        check_number(z_margin, "--z-margin", minimum=0)
        check_number(edge_margin, "--edge-margin", minimum=0)
        if max_cycles is not None and max_cycles < 1:
            raise ValueError(f"--max-cycles must be at least 1, got {max_cycles}")
        if workers is not None and workers < 1:
            raise ValueError(f"--processes must be at least 1, got {workers}")
        if chunk < 1:
            raise ValueError(f"--chunk must be at least 1 3D frame, got {chunk}")
        if window is not None and window < 1:
            raise ValueError(f"--window must be at least 1 frame, got {window}")
        if store_codec not in CODECS:
            raise ValueError(f"--store-codec must be one of {', '.join(CODECS)}, got {store_codec!r}")
        if store_layout not in ("auto", "xyz", "ray_depth"):
            raise ValueError(f"--store-layout must be auto, xyz or ray_depth, got {store_layout!r}")
        if triangulation not in ("auto", "fast", "lsq"):
            raise ValueError(f"--triangulation must be auto, fast or lsq, got {triangulation!r}")
        if device not in BACKENDS:
            raise ValueError(f"--device must be one of {', '.join(BACKENDS)}, got {device!r}")
        if device == "cuda" and scheduler is None:
            cuda_module()  # no driver / device / numba-cuda: CudaUnavailableError before anything is written
        if z_min_from is not None:
            if z_min is not None:
                raise ValueError("give either --z-min or --z-min-from, not both")
            z_min = reference_z_min(z_min_from, z_margin)
            info(f"z_min = {z_min:.3f} mm from {z_min_from} (nearest depth - {z_margin:g} mm)")
        rig = Rig.load(calibration)
        geometry = RigGeometry(rig)  # the checks' minimum phase map, reused by the cycle's or sequence's engine
        compensate, response_lut = resolve_compensation(compensate, response, rig)
        cap = read_capture(capture, max_cycles=1)  # checks the folder; the rest is read on demand
        why = lambda: why_no_points(cap.frames, ps, rig, DecodeOptions(z_min=z_min, **opts))  # noqa: E731
        check_sizes(rig, cap.frames, calibration, cap.patterns)
        referenced = open_frames(capture)  # a camera file (capture.json source), read on demand; else None
        n_files = len(referenced) if referenced is not None else len(list_frame_files(capture))
        cycles = n_files // len(cap.patterns) if max_cycles is None else min(max_cycles, n_files // len(cap.patterns))
        if cap.meta.get("exposures") is not None:  # an exposure bracket: fused per pixel into one cycle
            if window is not None or referenced is not None or max_cycles is not None:
                raise ValueError(f"{capture} is an exposure bracket (capture.json field exposures): it is "
                                 "reconstructed whole from its frames as one fused cycle; drop --window/--max-cycles")
            cap.frames = fuse_bracket(read_capture(capture).frames, cap.meta["exposures"], len(cap.patterns),
                                      cap.meta.get("bit_depth")).frames
            cycles = 1
        ps = reconstruction_plans(cap.patterns, method)
        with in_flag_words(z_min_from=True):  # relative phase, geometric method without z_min: before writing
            relative = check_plans(ps, rig, z_min, original=cap.patterns, source=str(capture / MANIFEST_NAME),
                                   allow_relative=allow_relative, geometry=geometry)
        check_plans_for(ps, compensate)  # --compensate disagreement without two equal-step frequencies
        opts = {"bit_depth": cap.meta.get("bit_depth"), "min_modulation": min_modulation, "edge_mask": edge_mask,
                "edge_margin": edge_margin, "compensate": compensate, "response": response_lut}
        methods = {p.direction: p.method for p in ps.plans}
        summary = {"capture": str(capture), "calibration": str(calibration), "out": str(out), "methods": methods,
                   "device": device,
                   "z_min": z_min, "cycles": cycles, "cycle_length": len(ps), "step": window,
                   "shape": list(cap.frames.shape[1:])}
        if relative:  # forced with --allow-relative: evaluate reads this
            summary["relative_phase"] = list(relative)
        sequence = not (cycles == 1 and window is None)
        for fmt in formats:
            check_choice(fmt, "--format", EXTRA_FORMATS)
        if formats and sequence:
            raise ValueError("--format writes one cycle's points; for a sequence use the point store "
                             "(or reconstruct one cycle with --max-cycles 1)")
        if mesh and sequence:
            raise ValueError("--mesh writes the faces into one cycle's points.ply; a sequence's ply/frame_*.ply "
                             "files hold points only (drop --mesh, or reconstruct one cycle with --max-cycles 1)")
        fp_options = {"method": method, "z_min": z_min, "window": window, "triangulation": triangulation,
                      "min_modulation": min_modulation, "cycles": cycles, "ply": ply, "mesh": mesh, "store": store,
                      "edge_mask": edge_mask, "edge_margin": edge_margin}
        if compensate is not None:  # (only) when set, so that other runs keep their fingerprint
            fp_options["compensate"] = compensate  # (only) when set, so that other runs keep their fingerprint
            fp_options["allow_relative"] = True
        if sequence and store:  # (only) store options join the fingerprint where they change it
            fp_options.update({"store_layout": store_layout, "store_quality": store_quality,
                               "store_codec": store_codec})
        client = None  # connected before anything is written
        if sequence and (workers or scheduler):
            client = connect(scheduler, workers, gpu=True) if device == "cuda" else connect(scheduler, workers)
        try:
            with open_output(out, overwrite=overwrite, inputs=[capture, calibration, z_min_from, response],
                             options=fp_options, resumable=sequence) as o:
                if not sequence:
                    try:
                        r = reconstruct_cycle(cap, geometry, CycleSettings(DecodeOptions(z_min=z_min, **opts), method,
                                                                      triangulation, device, allow_relative))
                    except EmptyMaskError:
                        raise ValueError(f"{capture}: no valid 3D point: "
                                         f"{why()}."
                                         " Nothing was written") from None
                    if not r.mask.any() and not allow_empty:
                        raise ValueError(f"{capture}: no valid 3D point: "
                                         f"{why()}. "
                                         "Nothing was written (pass --allow-empty to write it anyway)")
                    written = r.save(o.path, ply, mesh)
                    for fmt in dict.fromkeys(formats):
                        written[f"points_{fmt}"] = str(write_points(
                            o.path / f"points.{fmt}", r.points, measurement_attributes(r.points, r.sigma_z),
                            colors=r.colour))
                    summary["files"] = {k: str(Path(v).relative_to(o.path)) for k, v in written.items()}
                    summary.update(r.summary())
                    summary["path"] = r.path
                else:
                    settings = (DecodeSettings(DecodeOptions(z_min=z_min, **opts), triangulation,
                                               allow_relative=allow_relative, mode="window" if window else "cycle",
                                               step=window),
                                OutputSettings(ply, store, store_layout, store_quality, store_codec,
                                               frame_rate=read_meta(capture).get("frame_rate")),
                                RunSettings(device, progress=not (quiet or json_)))
                    seq = _sequence(o.path, CaptureFolder(str(capture), cycles * len(ps)), ps, geometry, settings,
                                    client, chunk)
                    summary.update(o.final_paths(seq))
                    if seq.get("empty_frames") == seq.get("frames_3d") and not allow_empty:
                        raise ValueError(f"{capture}: no valid 3D point in any frame of the sequence: "
                                         f"{why()} (pass --allow-empty to "
                                         "keep it)")
                summary["seconds"] = round(time.perf_counter() - t0, 3)
                write_json(o.path / "reconstruct.json", summary, units=RECONSTRUCT_UNITS)
        finally:
            if client is not None:
                close(client, own_cluster=scheduler is None)
        if json_:
            print_json(summary)
            return
        if quiet:
            return
        rows = [[k, v if not isinstance(v, (dict, list)) else json.dumps(to_jsonable(v))]
                for k, v in summary.items() if k not in ("files",)]
        console.print(make_table(f"reconstructed {capture} -> {out}", ["item", "value"], rows))
        info(f"done in {summary['seconds']} s")
