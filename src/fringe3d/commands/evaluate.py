"""``fringe3d evaluate RESULT --sphere/--plane/--ball-bar [--truth DIR]``: accuracy figures."""
from __future__ import annotations

import re
import warnings
from pathlib import Path

import typer

import numpy as np

from fringe3d.analyze.ball_bar import bar_spheres, find_spheres, read_spheres
from fringe3d.analyze.evaluation import cloud_ball_bar, evaluate_points, load_points, truth_frame_index
from fringe3d.analyze.truth_points import TruthPoints, load_truth_points
from fringe3d.patterns.method_registry import is_known, is_relative
from fringe3d.sim.truth import Truth
from fringe3d.utils.console import console, make_table, print_json, set_quiet, warn
from fringe3d.utils.jsonfile import write_json
from fringe3d.utils.output_folder import open_output_file
from fringe3d.commands.checks import check_number
from fringe3d.commands.output_options import overwrite_option

#: Units of evaluate.json: lengths (fits, errors, residuals) in mm; each figure may name its own.
EVALUATE_UNITS = {"length": "mm", "rms": "mm", "residuals": "mm", "angle": "rad", "share": "1",
                  "multiview": "pose errors mrad / um (named), lengths mm, coverage a share"}


def load_truth(folder: Path, info: dict, frame: int, shape) -> Truth | TruthPoints:
    """The simulator's truth for 3D frame ``frame`` of a reconstruction, checked against its size,
    or true surface points from a ``.npy`` (N, 3) mm / ``.ply`` file."""
    if folder.is_file() or folder.suffix in (".npy", ".ply"):
        return load_truth_points(folder)
    t = Truth.load(folder)
    if t.per_frame:
        t = t.frame(truth_frame_index(info, frame))
    if tuple(t.xyz.shape[:2]) != tuple(shape):
        raise ValueError(f"the truth in {folder} is {t.xyz.shape[1]}x{t.xyz.shape[0]} pixels but the point map is "
                         f"{shape[1]}x{shape[0]}; expected the truth of the capture that was reconstructed")
    return t


def relative_phase(info: dict) -> dict[str, str]:
    """``{direction: method}`` of the directions a reconstruction triangulated from wrapped or
    relative phase, from its reconstruct.json (``methods``, ``relative_phase``); empty otherwise."""
    methods = info.get("methods") if isinstance(info.get("methods"), dict) else {}
    out = {d: m for d, m in methods.items() if is_known(m) and is_relative(m)}
    for d in info.get("relative_phase") or []:
        out.setdefault(str(d), str(methods.get(d, "relative")))
    return out


def register(app: typer.Typer) -> None:
    @app.command("evaluate")
    def evaluate_cmd(
        result: Path = typer.Argument(..., help="Reconstruct output folder (points.npy / points.zarr), .npy or .ply."),
        sphere: bool = typer.Option(False, "--sphere", help="Probing error form/size and cross sections of a sphere."),
        plane: bool = typer.Option(False, "--plane", help="Flatness error and plane RMS."),
        ball_bar: bool = typer.Option(False, "--ball-bar", help="Sphere-spacing error of two spheres."),
        truth: Path = typer.Option(None, "--truth", help="Simulated capture (or its truth/ folder), or true surface "
                                   "points: .npy (N, 3) mm or .ply; for --ball-bar on a merged cloud the folder of "
                                   "`fringe3d simulate --views` (its spheres.json) or that file."),
        diameter: float = typer.Option(None, "--diameter", help="Calibrated sphere diameter (mm); default from truth."),
        distance: float = typer.Option(None, "--distance", help="Calibrated ball-bar length (mm); default from truth."),
        frame: int = typer.Option(0, "--frame", help="3D frame of a sequence store."),
        exclude: float = typer.Option(None, "--exclude",
                                      help="Share of worst points to drop (<= 0.003, VDI/VDE 2634-2); default: "
                                      "drop points beyond 5 robust sigmas."),
        overwrite: bool = overwrite_option(),
        json_: bool = typer.Option(False, "--json", help="Print one JSON object."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No tables."),
    ) -> None:
        """Accuracy figures of a reconstruction: fits, VDI/VDE 2634-2-style errors, error vs truth.

        Writes RESULT/evaluate.json and the maps plane_residuals.tif / sphere_residuals.tif /
        truth_error.tif (mm; folders only). With --truth the objects are picked from the
        simulator's object ids and the true sizes come from the noise-free truth surface; with a
        point file (.npy (N, 3) mm or .ply) the error is each point's distance to that surface.
        Outliers: by default points beyond 5 robust sigmas (1.4826 MAD) of the fit are dropped;
        --exclude SHARE applies the VDI/VDE 2634-2 rule instead. A warning flags a form error far
        above the fit RMS.

        A merged multi-view cloud (fringe3d merge's fused.ply) with --ball-bar gets the VDI/VDE
        2634-3 sphere-spacing test: the spheres are taken at their true centres (--truth: the
        simulated sequence's folder or spheres.json) or found by their calibrated --diameter
        (with --distance, the calibrated length); SD (mm and um) and each sphere's form error.

        A merge folder (fringe3d merge's output) with --truth SIMFOLDER (the simulated sequence)
        gets its figures against the truth in evaluate.json's multiview section: per-view pose
        errors (mrad, um at the object centre), fused RMS to the true surface (mm) and the
        coverage of that surface; with --ball-bar also the sphere spacing of its fused.ply.

        Example: fringe3d evaluate sphere-3d --sphere --truth sphere-capture --json

        Example: fringe3d evaluate merged/fused.ply --ball-bar --truth bar-views
        """
        set_quiet(quiet or json_)
        for value, option in ((diameter, "--diameter"), (distance, "--distance")):
            check_number(value, option, positive=True)
        check_number(exclude, "--exclude", minimum=0)
        if result.is_dir() and (result / "evaluate.json").exists() and not overwrite:
            raise ValueError(f"{result / 'evaluate.json'} exists; pass --overwrite to replace it")
        if sum([sphere, plane, ball_bar]) > 1:
            raise ValueError("choose one of --sphere, --plane, --ball-bar")
        if not (sphere or plane or ball_bar or truth is not None):
            raise ValueError("nothing to evaluate: give --sphere, --plane or --ball-bar (a fit), or --truth (the "
                             "error against the true surface); nothing was written")
        points, info = load_points(result, frame)
        out: dict = {"result": str(result), "frame": frame}
        relative = relative_phase(info)
        if relative:
            out["relative_phase"] = relative
            warn(f"{result} was triangulated from wrapped or relative phase ({relative}): its points are off by an "
                 "unknown number of fringe periods in depth, so these figures measure that offset, not the "
                 "measurement. Reconstruct it with an absolute method (fringe3d reconstruct names them).")
        if (result.is_dir() and (result / "merge.json").is_file() and not (sphere or plane)
                and (ball_bar or (truth is not None and truth.is_dir()))):
            if ball_bar:
                out["ball_bar"] = merged_ball_bar(points, truth, diameter, distance, exclude)
            if truth is not None and truth.is_dir() and ((truth / "truth.npz").is_file()
                                                         or (truth / "poses.json").is_file()):
                out["multiview"] = merge_truth(result, truth, points)
            return _report(out, result, overwrite, json_, quiet, relative)
        if ball_bar and points.ndim == 2 and (truth is None or truth.is_dir() or truth.suffix == ".json"):
            out["ball_bar"] = merged_ball_bar(points, truth, diameter, distance, exclude)
            return _report(out, result, overwrite, json_, quiet, relative)
        t = None
        if truth is not None and (truth.is_file() or truth.suffix in (".npy", ".ply")):
            t = load_truth(truth, info, frame, points.shape[:2])
        elif truth is not None:
            if points.ndim != 3:
                raise ValueError("--truth needs an organized point map (points.npy / points.zarr), not a PLY cloud")
            t = load_truth(truth, info, frame, points.shape[:2])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the figures carry their warnings; printed below
            out.update(evaluate_points(points, t, sphere=sphere, plane=plane, ball_bar=ball_bar, diameter=diameter,
                                       distance=distance, exclude=exclude, result=result))
        _report(out, result, overwrite, json_, quiet, relative)


def merge_truth(folder: Path, truth: Path, points) -> dict:
    """Figures of the merge in ``folder`` (its merge.json views, poses.json and fused ``points``)
    against a simulated sequence's truth (:func:`fringe3d.sim.turntable.read_turntable_truth`)."""
    from fringe3d.multiview.accuracy import merge_truth_figures
    from fringe3d.multiview.poses import read_poses
    from fringe3d.sim.turntable import read_turntable_truth
    from fringe3d.utils.jsonfile import read_json

    views = read_json(folder / "merge.json", "merge summary").get("views")
    if not isinstance(views, list) or not all(isinstance(v, dict) and isinstance(v.get("name"), str) for v in views):
        raise ValueError(f"{folder / 'merge.json'}: field 'views' must be a list of objects with a 'name'")
    names = [v["name"] for v in views]
    est = read_poses(folder / "poses.json")
    missing = [n for n in names if n not in est]
    if missing:
        raise ValueError(f"{folder / 'poses.json'}: no pose for view(s) {', '.join(missing)}")
    true, tp, tn = read_turntable_truth(truth, names)
    return merge_truth_figures(points, np.stack([est[n] for n in names]), true, tp.mean(0), tp, tn, names)


def merged_ball_bar(points, truth: Path | None, diameter: float | None, distance: float | None,
                    exclude: float | None) -> dict:
    """Ball-bar figures of a merged cloud: spheres at the true centres of ``truth`` (a simulated
    sequence's spheres.json), or found by the calibrated ``diameter``."""
    if truth is not None:
        centres, radius = bar_spheres(*read_spheres(truth))
        L = distance if distance is not None else float(np.linalg.norm(centres[1] - centres[0]))
        d = diameter if diameter is not None else 2 * radius
    else:
        if diameter is None or distance is None:
            raise ValueError("--ball-bar on a merged cloud needs the spheres: --truth SIMFOLDER (its spheres.json) "
                             "or the bar's calibrated --diameter and --distance")
        radius, d, L = 0.5 * diameter, diameter, distance
        centres = find_spheres(points, radius)
    return cloud_ball_bar(points, centres, radius, L, d, exclude)


def _report(out: dict, result: Path, overwrite: bool, json_: bool, quiet: bool, relative) -> None:
    for sect in ("sphere", "plane", "ball_bar"):
        for msg in out.get(sect, {}).get("warnings", []):
            warn(msg)
    if result.is_dir():
        with open_output_file(result / "evaluate.json", overwrite=overwrite):
            write_json(result / "evaluate.json", out, units=EVALUATE_UNITS)
    if json_:
        print_json(out)
        return
    if quiet:
        return
    rows = []
    for sect in ("truth", "sphere", "plane", "ball_bar", "multiview"):
        for k, v in out.get(sect, {}).items():
            if not isinstance(v, (dict, list, tuple)):
                rows.append([f"{sect}.{k}", "n/a" if v is None else v, figure_unit(k, v)])
    for v in out.get("multiview", {}).get("views", []):
        rows += [[f"multiview.{v['name']}.rotation_error", v["rotation_error_mrad"], "mrad"],
                 [f"multiview.{v['name']}.translation_error", v["translation_error_um"], "um"]]
    for k, sph in enumerate(out.get("ball_bar", {}).get("spheres", [])):
        for key in ("form", "size", "diameter", "rms"):
            if sph.get(key) is not None:
                rows.append([f"ball_bar.sphere_{k}.{key}", sph[key], "mm"])
    title = f"evaluation of {result}" + (" - RELATIVE PHASE, NOT A MEASUREMENT" if relative else "")
    console.print(make_table(title, ["figure", "value", "unit"], rows))


#: Figures that are counts, ids or shares (no unit); every other figure of evaluate is a length in mm.
_UNITLESS = re.compile(r"^n_|_count$|count|object_id|index|coverage|share|fraction|ratio|window")


def figure_unit(key: str, value) -> str:
    """The unit of evaluate's figure ``key``: ``"mm"`` for lengths, ``""`` for counts, ids, shares
    and figures without a value (None)."""
    if value is not None and key.endswith("_mm"):
        return "mm"
    if value is None or isinstance(value, (bool, int)) or _UNITLESS.search(key):
        return ""
    if key.endswith("_um"):
        return "um"
    if key.endswith("_mrad"):
        return "mrad"
    return "mm"
