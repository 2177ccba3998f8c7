"""``fringe3d simulate``: render a capture folder (frames + manifest + truth/ + rig.json)."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import typer

from fringe3d.commands.deprecated import AliasCommand
from fringe3d.commands.checks import check_number, parse_exposures, parse_stage_sigma
from fringe3d.commands.output_options import overwrite_option
from fringe3d.utils.output_folder import open_output
from fringe3d.commands.vocabulary import set_option, set_word
from fringe3d.patterns.manifest import PatternSet
from fringe3d.sim.scene_file import load_scene
from fringe3d.sim.settings import RenderChanges
from fringe3d.sim.simulate import simulate_capture
from fringe3d.sim.turntable import simulate_turntable
from fringe3d.utils.console import console, info, make_table, print_json, set_quiet


#: Most frames one ``simulate`` run renders. Frames and truth are written as they are rendered (memory
#: does not grow with the take), so the bound only stops a mistyped count from filling the disk.
MAX_SIM_FRAMES = 1_000_000


def register(app: typer.Typer) -> None:
    @app.command("simulate", cls=AliasCommand)
    def simulate(
        out: Path = typer.Option(..., "-o", "--output", help="Output capture folder."),
        preset: str = typer.Option("tiny", help="Rig preset: macro, well-designed, microscope, high-speed, tiny."),
        scene: str = typer.Option(None, help="Scene name (sphere, plane, spheres, step, board, sculpture, mesh, "
                                             "falling-balls, wing, textured-spheres, shiny-part, printed-part, "
                                             "sphere-bar) "
                                             "or a JSON scene file; "
                                             "default: the preset's."),
        patterns: str = set_option(None, "Pattern set: calibration (31 frames, both directions), three-frequency-v, "
                                         "three-frequency-h, phase-shift, two-frequency, hybrid, ftp, modified-ftp, "
                                         "gray-code, ... or a manifest.json; default: the preset's."),
        frames: int = typer.Option(None, help="Total frames (a multiple of the pattern count); default one cycle."),
        frame_rate: float = typer.Option(None, "--frame-rate", help="Frames per second (Hz)."),
        exposure: float = typer.Option(None, help="Exposure time (s), at most 1/frame-rate."),
        exposures: str = typer.Option(None, help="HDR exposure bracket: comma-separated exposure times (s), "
                                                 "shortest first, e.g. 0.000625,0.0025,0.01; one pattern cycle "
                                                 "per exposure (decode fuses them per pixel)."),
        noise: float = typer.Option(None, help="Read-noise sigma as a fraction of full scale (e.g. 0.01)."),
        gain: float = typer.Option(None, help="Camera gain (multiplies the signal; above ~1.2 the bright "
                                              "frames clip at full scale: an overexposed capture)."),
        read_noise_e: float = typer.Option(None, "--read-noise-e", help="EMVA 1288 camera: dark (read) noise "
                                           "sigma in electrons; switches to the EMVA model (Poisson shot noise, "
                                           "well clip, quantisation)."),
        full_well: float = typer.Option(None, "--full-well", help="EMVA 1288 camera: electrons at full scale "
                                        "(default 10000); switches to the EMVA model."),
        defocus: float = typer.Option(None, help="Projector defocus: Gaussian sigma in projector pixels."),
        bit_depth: int = typer.Option(0, "--bit-depth", help="Camera bit depth 8/10/12/16 (0: the preset's)."),
        ideal: bool = typer.Option(False, "--ideal", help="Analytic sinusoids, no projector pixelation or defocus."),
        seed: int = typer.Option(0, help="Noise seed: the same seed gives the same frames."),
        views: int = typer.Option(None, "--views", help="Multi-view: render N views on a virtual turntable "
                                  "(OUT/view-00 ... one capture folder each, OUT/poses.json with the stage's "
                                  "and the true view -> model poses)."),
        turntable_step: float = typer.Option(None, "--turntable-step", help="With --views: table turn between "
                                             "views (degrees); default 360/N."),
        stage_sigma: str = typer.Option(None, "--stage-sigma", help="With --views: the stage's stated 1-sigma "
                                        "error as ROT_MRAD,TRANS_MM (translation at the object centre); the "
                                        "poses in OUT/poses.json carry a seeded error of that size. Default 2,0.2."),
        overwrite: bool = overwrite_option(),
        json_: bool = typer.Option(False, "--json", help="Print a JSON summary."),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bars."),
    ) -> None:
        """Simulate a camera-projector capture with ground truth.

        Writes OUT/frames/*.png, OUT/manifest.json, OUT/capture.json, OUT/truth/ and OUT/rig.json.
        Each frame (and a moving scene's per-frame truth) is written as it is rendered, so memory
        does not grow with --frames; OUT stays marked incomplete (fringe3d.json) until the end.
        An interrupted run resumes when the same command is run again: the frames it wrote are kept.

        With --views N: OUT/view-00 ... OUT/view-NN are capture folders of the scene turned on a
        virtual turntable by --turntable-step degrees each, OUT/poses.json holds per view the pose
        the stage reports ('matrix', what fringe3d merge --poses reads, off by --stage-sigma),
        the true pose ('true_matrix') and the table angle, and OUT/spheres.json the true spheres
        (for fringe3d evaluate FUSED.ply --ball-bar --truth OUT).

        Example: fringe3d simulate --preset macro --scene sphere --set calibration -o sphere-capture

        Example: fringe3d simulate --scene sculpture --views 8 --turntable-step 10 -o turntable
        """
        set_quiet(quiet or json_)
        extra: dict = {"ideal": True} if ideal else {}
        patterns = set_word("simulate", patterns)
        check_number(gain, "--gain", minimum=0)
        if gain is not None:
            extra["gain"] = gain
        for value, option in ((frame_rate, "--frame-rate"), (exposure, "--exposure")):
            check_number(value, option, positive=True)
        check_number(noise, "--noise", minimum=0, maximum=1)
        check_number(read_noise_e, "--read-noise-e", minimum=0)
        check_number(full_well, "--full-well", positive=True)
        if read_noise_e is not None or full_well is not None:
            if noise is not None:
                raise ValueError("--noise is the simple model's read noise; with --read-noise-e/--full-well "
                                 "(the EMVA 1288 model) give the read noise in electrons instead")
            extra["noise_model"] = "emva"
            extra["read_noise_e"] = read_noise_e if read_noise_e is not None else 0.0
            if full_well is not None:
                extra["full_well"] = full_well
        check_number(defocus, "--defocus", minimum=0)
        bracket = parse_exposures(exposures, "--exposures")
        if bracket is not None and exposure is not None:
            raise ValueError("give --exposure (one exposure) or --exposures (a bracket), not both")
        if frames is not None and not 1 <= frames <= MAX_SIM_FRAMES:
            raise ValueError(f"--frames must be between 1 and {MAX_SIM_FRAMES}, got {frames}")
        inputs = [Path(x) for x in (scene, patterns) if x is not None and Path(x).suffix == ".json"]
        if scene is not None and Path(scene).suffix == ".json":
            load_scene(scene)  # a bad scene file fails before any output exists
        if patterns is not None and Path(patterns).suffix == ".json":
            PatternSet.load(patterns)
        multi = multiview_options(views, turntable_step, stage_sigma, bracket)
        options = dict(preset=preset, scene=scene, patterns=patterns, frames=frames, frame_rate=frame_rate,
                       exposure=exposure, noise=noise, gain=gain, defocus=defocus, bit_depth=bit_depth, ideal=ideal,
                       seed=seed, exposures=bracket, read_noise_e=read_noise_e, full_well=full_well, **multi)
        with open_output(out, overwrite=overwrite, inputs=inputs, options=options, resumable=True) as o:
            if o.resumed:
                info(f"resuming the unfinished capture in {out}: frames already written are kept")
            changes = RenderChanges(frame_rate=frame_rate, exposure=exposure, noise=noise, defocus=defocus,
                                    bit_depth=bit_depth, others=extra)
            if multi:
                summary = o.final_paths(simulate_turntable(
                    o.path, preset, scene, patterns, views=multi["views"], step_deg=multi["turntable_step"],
                    stage_sigma=multi["stage_sigma"], progress=not (quiet or json_), frames=frames,
                    seed=seed, resume=o.resumed, render=changes))
                summary.pop("captures")
            else:
                summary = o.final_paths(simulate_capture(o.path, preset, scene, patterns, frames=frames, seed=seed,
                                                     render=replace(changes, exposures=bracket),
                                                     progress=not (quiet or json_), resume=o.resumed))
        if json_:
            print_json(summary)
            return
        if not quiet:
            rows = [[k, str(v)] for k, v in summary.items()]
            console.print(make_table("simulated capture", ["field", "value"], rows))


def multiview_options(views: int | None, step: float | None, stage_sigma: str | None, bracket) -> dict:
    """``{views, turntable_step, stage_sigma}`` from simulate's multi-view flags, checked ({} without
    --views); ValueError naming the flag."""
    if views is None:
        for value, flag in ((step, "--turntable-step"), (stage_sigma, "--stage-sigma")):
            if value is not None:
                raise ValueError(f"{flag} needs --views N (a multi-view turntable sequence)")
        return {}
    if not 2 <= views <= 360:
        raise ValueError(f"--views must be between 2 and 360, got {views}")
    if bracket is not None:
        raise ValueError("--views renders one exposure per view; give --exposure, not --exposures")
    check_number(step, "--turntable-step")
    if step is not None and not (0 < abs(step) <= 360):
        raise ValueError(f"--turntable-step must be a non-zero angle within +-360 degrees, got {step}")
    return {"views": views, "turntable_step": 360.0 / views if step is None else float(step),
            "stage_sigma": parse_stage_sigma(stage_sigma if stage_sigma is not None else "2,0.2", "--stage-sigma")}
