"""``fringe3d calibrate``: calibrate a camera-projector rig from board pose captures."""
from __future__ import annotations

from pathlib import Path

import typer

from fringe3d.commands.deprecated import AliasCommand
from fringe3d.calibrate.calibration_file import export_rig_opencv_yaml, load_calibration, rig_for_export
from fringe3d.calibrate.evaluation import compare_to_truth
from fringe3d.calibrate.gates import AcceptanceGateError
from fringe3d.calibrate.model_choice import check_dist_option
from fringe3d.calibrate.opencv_file import load_opencv_calibration, parse_node_map, parse_size
from fringe3d.calibrate.code_mapping import DEFAULT_WINDOW
from fringe3d.calibrate.session import board_from_options, calibrate_to_files
from fringe3d.calibrate.session_settings import CalibrationOutput, FitSettings, ObservationSettings
from fringe3d.calibrate.square_boards import BOARD_KINDS, squares_from_inner_corners
from fringe3d.io.importer import parse_size as parse_projector_size
from fringe3d.sim.calibration_session import PoseRanges, SessionImaging, SessionOptics, simulate_session
from fringe3d.utils.console import console, info, make_table, print_json, set_quiet
from fringe3d.commands.checks import check_number
from fringe3d.commands.output_options import overwrite_option
from fringe3d.commands.vocabulary import set_option, set_word
from fringe3d.utils.output_folder import open_output, open_output_file


#: Largest board side (circles) and pose count accepted: bounds OpenCV's grid search and memory.
MAX_BOARD_SIDE = 100
MAX_POSES = 500


def register(app: typer.Typer) -> None:
    @app.command("calibrate", cls=AliasCommand)
    def calibrate(
        inputs: list[Path] = typer.Argument(None, help="Pose capture folders, or a session folder holding them "
                                                       "(none with --import-opencv or --export-opencv)."),
        output: Path = typer.Option(Path("calib.json"), "-o", "--output", help="Calibration JSON to write."),
        board_kind: str = typer.Option("circles", "--board", help="Board kind: circles (circle grid), chessboard "
                                                                  "(cv2.findChessboardCornersSB) or charuco "
                                                                  "(cv2.aruco.CharucoDetector, partial views)."),
        cols: int = typer.Option(None, help="Board circles per row (chessboard/charuco: squares per row, one "
                                            "more than OpenCV's inner corners); default 9."),
        rows: int = typer.Option(None, help="Board rows of circles (chessboard/charuco: rows of squares); "
                                            "default 9."),
        inner_corners: str = typer.Option(None, "--inner-corners", help="Chessboard/charuco size as OpenCV tools "
                                                                        "count it: COLSxROWS inner corners "
                                                                        "(patternSize), e.g. 9x6 = --cols 10 "
                                                                        "--rows 7."),
        spacing: float = typer.Option(None, help="Board circle spacing or square size (mm); default from "
                                                 "session.json."),
        radius: float = typer.Option(None, help="Board circle radius (mm); default spacing/4."),
        asymmetric: bool = typer.Option(False, help="OpenCV asymmetric circle grid."),
        bright: bool = typer.Option(False, help="Bright circles on a dark board."),
        marker: float = typer.Option(None, help="ChArUco marker size (mm); default 0.7 x the square size."),
        dictionary: str = typer.Option("DICT_4X4_50", help="ChArUco ArUco dictionary (cv2.aruco.DICT_* name)."),
        homography_window: int = typer.Option(DEFAULT_WINDOW, help="Gray-code poses: side (camera px) of the "
                                                                   "window of each corner's local homography."),
        model: str = typer.Option(None, help="'pinhole' (camera frame = world) or 'telecentric' (projector "
                                             "frame = world); default from session.json or pinhole."),
        camera_dist: str = typer.Option("auto", help="Camera distortion: auto (chosen by held-out reprojection "
                                                     "error across poses), none, k1, k1k2, k1k2p, full."),
        projector_dist: str = typer.Option("auto", help="Projector distortion: auto (as --camera-dist), none "
                                                        "(linear model), k1, k1k2, k1k2p, full."),
        accept_poor: bool = typer.Option(False, "--accept-poor", help="Write the calibration even when it fails "
                                                                      "an acceptance gate (the file records the "
                                                                      "failed gates)."),
        min_modulation: float = typer.Option(0.1, "--min-modulation-share",
                                             help="Reject centres whose modulation is below this share (a "
                                                  "fraction, 0-1) of the image's 95th-percentile modulation "
                                                  "(--min-modulation: deprecated spelling)."),
        phase_window: str = typer.Option("bilinear", help="Phase at each circle centre: 'bilinear' (Eq. 2.30-2.31), "
                                                          "or a modulation-weighted local fit over a radius: 'auto' "
                                                          "(half the circle spacing) or a number of pixels."),
        no_refine: bool = typer.Option(False, "--no-refine", help="Telecentric rigs: skip the joint LM "
                                                                   "refinement (the dissertation's sequential "
                                                                   "ch. 3 method)."),
        plot: Path = typer.Option(None, help="Residual plot PNG (default: OUTPUT with .png)."),
        no_plot: bool = typer.Option(False, "--no-plot", help="Do not write the residual plot."),
        yaml: Path = typer.Option(None, help="Also export OpenCV FileStorage YAML here."),
        simulate: str = typer.Option(None, help="First render a simulated session with this preset (macro, "
                                                "well-designed, microscope, tiny) into the single input folder, "
                                                "then calibrate it and compare with the true rig."),
        poses: int = typer.Option(12, help="--simulate: number of board poses."),
        seed: int = typer.Option(0, help="--simulate: random seed (poses and noise)."),
        noise_free: bool = typer.Option(False, "--noise-free", help="--simulate: no sensor noise, 16-bit frames."),
        defocus: float = typer.Option(None, help="--simulate: projector defocus (projector px)."),
        camera_scale: float = typer.Option(1.0, help="--simulate: camera resolution factor (e.g. 0.5)."),
        set_name: str = set_option(None, "The pattern set. With --simulate: calibration (the calibration phase "
                                         "set, default) or gray-code (Gray-code columns and rows with inverses, "
                                         "white, black). Poses of another tool (folders of numbered frames, no "
                                         "manifest): opencv-graycode (OpenCV GrayCodePattern: column pairs, row "
                                         "pairs, white, black; needs --projector-size)."),
        stripe: float = typer.Option(None, help="--simulate --set gray-code: narrowest stripe (projector "
                                                "px); default from the defocus (1 px when sharp = OpenCV's "
                                                "layout)."),
        partial: int = typer.Option(0, help="--simulate: this many poses show only part of the board to the "
                                            "camera (ChArUco)."),
        import_opencv: list[Path] = typer.Option(None, "--import-opencv", help="Do not calibrate: read K/dist/R/T "
                                                 "from this OpenCV FileStorage YAML/XML and write the rig JSON to "
                                                 "-o; repeat it for OpenCV's two files (intrinsics.yml: M1 D1 M2 "
                                                 "D2, extrinsics.yml: R T), or give the folder holding them."),
        export_opencv: Path = typer.Option(None, "--export-opencv", help="Do not calibrate: write this existing "
                                           "calibration (or rig) JSON as an OpenCV FileStorage YAML to -o "
                                           "(K, dist, sizes, R, T in mm; rms and periods when known)."),
        node: list[str] = typer.Option(None, "--node", help="--import-opencv: KEY=NODE maps a node name, e.g. "
                                                            "cam_int=K1 (keys: cam_int cam_dist proj_int proj_dist "
                                                            "R T cam_size proj_size); cam_dist=none or "
                                                            "proj_dist=none: no lens distortion."),
        camera_size: str = typer.Option(None, "--camera-size", help="--import-opencv: camera WxH when the file "
                                                                     "has no size node."),
        projector_size: str = typer.Option(None, "--projector-size", help="--set opencv-graycode: the projector "
                                                                           "WxH (px); "
                                                                           "--import-opencv: projector WxH when "
                                                                           "the file has no size node."),
        unit: str = typer.Option("mm", "--unit", help="--import-opencv: unit of T in the file (mm or m)."),
        overwrite: bool = overwrite_option(),
        json_: bool = typer.Option(False, "--json", help="Print the figures as one JSON object."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bars or tables."),
    ) -> None:
        """Calibrate camera and projector from board poses (circle grid, chessboard or ChArUco)
        through the phase domain (works with a defocused projector) or through Gray code and
        local homographies, writing a versioned calibration JSON that Rig.load reads.

        Example: fringe3d calibrate session/ -o calib.json --yaml calib.yaml

        Example (simulated): fringe3d calibrate sim-session/ --simulate macro --poses 12 --noise-free -o calib.json

        Example (another tool's session): fringe3d calibrate poses/ --set opencv-graycode
        --projector-size 1024x768 --board chessboard --cols 9 --rows 7 --spacing 20 -o calib.json
        """
        set_quiet(quiet or json_)
        if export_opencv is not None:
            _export(export_opencv, output, bool(import_opencv or inputs), overwrite, json_, quiet)
            return
        if import_opencv:
            with open_output_file(output, overwrite=overwrite, inputs=list(import_opencv)):
                _import(import_opencv, output, node, camera_size, projector_size, unit, json_, quiet)
            return
        for value, option in ((spacing, "--spacing"), (radius, "--radius"), (camera_scale, "--camera-scale")):
            check_number(value, option, positive=True)
        check_number(min_modulation, "--min-modulation-share", minimum=0, maximum=1)
        check_number(defocus, "--defocus", minimum=0)
        check_number(stripe, "--stripe", minimum=1)
        check_number(marker, "--marker", positive=True)
        check_dist_option(camera_dist, "--camera-dist")
        check_dist_option(projector_dist, "--projector-dist")
        if board_kind not in BOARD_KINDS:
            raise ValueError(f"--board must be one of {', '.join(BOARD_KINDS)}, got {board_kind!r}")
        stated = {"board_kind": board_kind != "circles", "cols": cols, "rows": rows, "inner_corners": inner_corners,
                  "radius": radius, "asymmetric": asymmetric, "bright": bright, "marker": marker}
        cols, rows = board_counts(board_kind, cols, rows, inner_corners)
        sim_patterns, layout = pattern_words(set_word("calibrate", set_name), simulate)
        if not 5 <= homography_window <= 501:
            raise ValueError(f"--homography-window must be between 5 and 501 camera px, got {homography_window}")
        least = 2 if board_kind == "circles" else 3
        for value, option in ((cols, "--cols"), (rows, "--rows")):
            if not least <= value <= MAX_BOARD_SIDE:
                what = "circles" if board_kind == "circles" else "squares"
                raise ValueError(f"{option} must be between {least} and {MAX_BOARD_SIDE} {what}, got {value}")
        if not 1 <= poses <= MAX_POSES:
            raise ValueError(f"--poses must be between 1 and {MAX_POSES}, got {poses}")
        if not 0 <= partial <= poses:
            raise ValueError(f"--partial must be between 0 and --poses ({poses}), got {partial}")
        if not inputs:
            raise ValueError("give the pose capture folders (or a session folder) to calibrate, "
                             "or --import-opencv FILE")
        if spacing is None and not simulate and layout is None:
            check_board_flags_need_spacing(**stated)
        board = board_from_options(cols, rows, spacing, radius, asymmetric, bright, board_kind, marker, dictionary)
        size = None
        if layout is not None:
            size = parse_projector_size(projector_size)
            if size is None:
                raise ValueError("--set opencv-graycode needs the projector size: --projector-size WIDTHxHEIGHT, "
                                 "e.g. 1024x768")
            if board is None:
                raise ValueError("--set opencv-graycode sessions carry no board description: give --board, --cols, "
                                 "--rows and --spacing")
        truth = None
        if simulate:
            if len(inputs) != 1:
                raise ValueError("--simulate writes one session folder: give exactly one input folder")
            sim_board = board if board is not None else (None if board_kind == "circles" else (board_kind, cols, rows))
            with open_output(inputs[0], overwrite=overwrite,
                             options={"preset": simulate, "poses": poses, "seed": seed, "defocus": defocus,
                                      "board": [board_kind, cols, rows, spacing, radius, asymmetric, bright,
                                                marker, dictionary],
                                      "camera_scale": camera_scale, "noise_free": noise_free,
                                      "patterns": sim_patterns, "stripe": stripe, "partial": partial}) as o:
                ss = simulate_session(simulate, n_poses=poses, seed=seed, patterns=sim_patterns, board=sim_board,
                                      folder=o.path, progress=not (quiet or json_),
                                      optics=SessionOptics(camera_scale=camera_scale, defocus=defocus),
                                      imaging=SessionImaging(noise=not noise_free, stripe=stripe),
                                      pose_ranges=PoseRanges(partial=partial))
            truth = ss.rig
        plot_path = None if no_plot else (plot or output.with_suffix(".png"))
        try:
            with open_output_file(output, plot_path, yaml, overwrite=overwrite, inputs=inputs):
                s = calibrate_to_files(inputs, output, board, model, progress=not (quiet or json_), layout=layout,
                                       projector_size=size,
                                       observe=ObservationSettings(min_modulation_share=min_modulation,
                                                                   phase_window=phase_window,
                                                                   homography_window=homography_window),
                                       fit=FitSettings(camera_dist=camera_dist, projector_dist=projector_dist,
                                                       telecentric_refine=not no_refine),
                                       files=CalibrationOutput(plot=plot_path, yaml=yaml, accept_poor=accept_poor))
        except AcceptanceGateError as e:  # show the figures, then the error (exit 2, nothing written)
            _show(e.summary, json_, quiet)
            raise
        if truth is not None:
            s["truth_comparison"] = compare_to_truth(load_calibration(output).rig, truth)
        _show(s, json_, quiet)


def _show(s: dict, json_: bool, quiet: bool) -> None:
    """Print a calibration summary: JSON, or tables of residuals, model choice and acceptance gates."""
    if json_:
        print_json(s)
        return
    if quiet:
        return
    rows_ = [[p["name"], p["points"], p["camera_rms_px"], p["projector_rms_px"]] for p in s["poses"]]
    console.print(make_table("per-pose reprojection RMS (px)", ["pose", "points", "camera", "projector"], rows_))
    console.print(make_table("overall", ["figure", "value"], [[k, v] for k, v in s["rms"].items()]))
    if "truth_comparison" in s:
        console.print(make_table("calibrated vs true rig", ["figure", "error"],
                                 [[k, v] for k, v in s["truth_comparison"].items()]))
    q = s.get("acceptance", {})
    for dev, c in q.get("model_choice", {}).items():
        errs = ", ".join(f"{m} {v:.4g}" if v is not None and v < float("inf") else f"{m} failed"
                         for m, v in c.get("held_out_rms_px", {}).items())
        info(f"{dev} distortion: {c['chosen']} ({errs or c.get('reason')}; held-out RMS px)")
    for d in q.get("dropped_poses", []):
        console.print(f"dropped outlier pose {d['name']}: camera {d['camera_rms_px']:.3g} px, projector "
                      f"{d['projector_rms_px']:.3g} px ({q.get('outlier_rule')})")
    gates = q.get("gates", [])
    if gates:
        console.print(make_table("acceptance gates", ["gate", "result", "value", "limit"],
                                 [[g["name"], "pass" if g["passed"] else "FAIL", g["value"], g["limit"]]
                                  for g in gates]))
    for name in s["skipped_poses"]:
        console.print(f"skipped (board not found): {name}")
    for k, v in s["written"].items():
        info(f"wrote {k}: {v}")


def check_board_flags_need_spacing(**given) -> None:
    """Board flags without ``--spacing`` would be ignored (the board then comes from the session's
    session.json): ``ValueError`` naming them. ``given`` maps each flag's name to its value
    (None or False: not given)."""
    named = [f"--{k.replace('_', '-')}" if k != "board_kind" else "--board" for k, v in given.items()
             if v is not None and v is not False]
    if named:
        raise ValueError(f"{', '.join(named)} describe(s) the board only together with --spacing; without "
                         "--spacing the board is read from the session's session.json and these would be "
                         "ignored. Give the whole board (--spacing too) or leave them out")


def board_counts(board_kind: str, cols: int | None, rows: int | None, inner_corners: str | None) -> tuple[int, int]:
    """(cols, rows) of the board: ``--inner-corners`` (chessboard/charuco, OpenCV's count) turned
    into squares, else ``--cols``/``--rows`` (default 9); both given must agree."""
    if inner_corners is None:
        return (9 if cols is None else cols), (9 if rows is None else rows)
    if board_kind == "circles":
        raise ValueError("--inner-corners counts a chessboard's or ChArUco board's corners; a circle grid is "
                         "--cols/--rows circles")
    squares = squares_from_inner_corners(inner_corners)
    for given, n, option in ((cols, squares[0], "--cols"), (rows, squares[1], "--rows")):
        if given is not None and given != n:
            raise ValueError(f"--inner-corners {inner_corners} is a board of {squares[0]}x{squares[1]} squares, but "
                             f"{option} says {given}; give one of them")
    return squares


def _export(source: Path, output: Path, other_inputs: bool, overwrite: bool, json_: bool, quiet: bool) -> None:
    """``--export-opencv``: an existing calibration / rig JSON -> OpenCV FileStorage YAML at ``-o``."""
    if other_inputs:
        raise ValueError("--export-opencv converts an existing calibration: give no pose folders and no "
                         "--import-opencv")
    if output.suffix.lower() not in (".yaml", ".yml"):
        raise ValueError(f"--export-opencv writes an OpenCV YAML: -o must end in .yaml or .yml, got {output}")
    rig, figures = rig_for_export(source)  # every check before the output exists
    with open_output_file(output, overwrite=overwrite, inputs=[source]):
        export_rig_opencv_yaml(rig, output, figures)
    s = {"exported": str(source), "written": {"yaml": str(output)}, "baseline_mm": rig.baseline}
    if json_:
        print_json(s)
    elif not quiet:
        info(f"wrote {output} (OpenCV FileStorage) from {source}")


def _import(path: list[Path], output: Path, node, camera_size, projector_size, unit: str, json_: bool,
            quiet: bool) -> None:
    """``--import-opencv``: OpenCV FileStorage calibration -> fringe3d rig JSON (``Rig.load`` reads it)."""
    rig = load_opencv_calibration(path, parse_node_map(node), parse_size(camera_size, "--camera-size"),
                                  parse_size(projector_size, "--projector-size"), unit)
    rig.save(output)
    s = {"imported": " + ".join(map(str, path)), "written": {"rig": str(output)}, "baseline_mm": rig.baseline,
         "camera": rig.camera.to_dict(), "projector": rig.projector.to_dict()}
    if json_:
        print_json(s)
    elif not quiet:
        info(f"imported {s['imported']}: baseline {rig.baseline:.3f} mm")
        info(f"wrote rig: {output}")


def pattern_words(set_name: str | None, simulate: str | None) -> tuple[str, str | None]:
    """``--set`` as (the simulator's pattern word, the layout of another tool's poses or None).

    With ``--simulate`` the set is simulated (calibration, the default, or gray-code); without, it
    names what another tool projected (opencv-graycode, the only such layout of a calibration)."""
    if simulate:
        if set_name not in (None, "calibration", "gray-code"):
            raise ValueError(f"--simulate --set must be calibration or gray-code, got {set_name!r}")
        return {"calibration": "phase", None: "phase"}.get(set_name, set_name or "phase"), None
    if set_name is not None and set_name != "opencv-graycode":
        raise ValueError(f"--set for another tool's calibration session must be opencv-graycode (OpenCV's "
                         f"GrayCodePattern frames in each pose folder), got {set_name!r}")
    return "phase", set_name
