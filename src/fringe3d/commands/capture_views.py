"""``fringe3d capture --views N --stage SPEC``: one capture folder per stage position and poses.json.

The stage is ``virtual[:STEP_DEG][?axis=X,Y,Z&point=X,Y,Z]`` (the simulator's turntable under the
virtual rig's scene: it turns the object the virtual camera films) or a real one
(:func:`fringe3d.devices.stage_backends.open_stage`). Poses (view -> model, model = view 0's camera frame)
come from the turntable axis file (``--stage-axis``), or for the virtual stage from its own axis
(the simulator's truth); a real stage without an axis file records its angles only.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fringe3d.devices import DeviceSpec, option
from fringe3d.devices.acquire import CaptureTiming
from fringe3d.devices.stage_backends import STAGE_BACKENDS, open_stage
from fringe3d.devices.views import capture_views, stage_positions
from fringe3d.sim.turntable import VirtualStage, open_virtual_stage, write_spheres
from fringe3d.utils.console import progress_bar


def check_views_options(mode) -> None:
    """Refuse --stage / --stage-axis without --views, --views without --stage, and a bad spec."""
    if mode.views is None:
        extra = [f for f, v in (("--stage", mode.stage), ("--stage-axis", mode.stage_axis)) if v is not None]
        if extra:
            raise ValueError(f"{' and '.join(extra)} belong to a multi-view capture: add --views N")
        return
    if not 2 <= mode.views <= 360:
        raise ValueError(f"--views must be between 2 and 360, got {mode.views}")
    if mode.stage is None:
        raise ValueError("--views needs --stage, e.g. --stage virtual:30 or --stage grbl:/dev/ttyUSB0?step=30")
    spec = DeviceSpec.parse(mode.stage)
    if spec.backend not in STAGE_BACKENDS:
        raise ValueError(f"unknown stage backend {spec.backend!r}; expected one of {', '.join(STAGE_BACKENDS)} "
                         "(e.g. --stage virtual:30)")
    stage_step(spec, mode.views)
    if mode.stage_axis is not None:
        from fringe3d.multiview.axis import read_axis  # heavy (scipy.spatial): only with --stage-axis

        read_axis(mode.stage_axis)


def stage_step(spec: DeviceSpec, views: int) -> float:
    """The turn between views (deg): the virtual stage's ``virtual:STEP``, any stage's ``?step=``,
    else 360 / views."""
    text = option(spec.options, "step", "") or (spec.ident if spec.backend == "virtual" else "")
    if not text:
        return 360.0 / views
    try:
        step = float(text)
    except ValueError:
        step = float("nan")
    if not np.isfinite(step) or step == 0:
        raise ValueError(f"--stage {spec.backend}: the step is a non-zero angle in degrees, got {text!r}")
    return step


def _open_stage(spec: DeviceSpec, projector):
    if spec.backend == "virtual":
        return open_virtual_stage(spec, projector)
    return open_stage(spec)


def capture_views_mode(proj, cam, loaded: tuple, meta: dict, dev, mode, run) -> dict:
    """Run the multi-view capture into ``run.output`` (already guarded) and write poses.json.

    ``loaded`` is ``(patterns, images to show, bit-plane counts or None)``; ``meta`` the
    ``capture.json`` fields every view gets. Returns the command's summary."""
    ps, show, planes = loaded
    spec = DeviceSpec.parse(mode.stage)
    positions = stage_positions(mode.views, stage_step(spec, mode.views))
    out = Path(run.output)
    seq = {"patterns": ps, "images": show, "cycles": run.cycles, "planes": planes, "extra_meta": meta,
           "timing": CaptureTiming(dev.sync, dev.settle, dev.timeout, dev.frame_rate, dev.exposures)}
    stage = _open_stage(spec, proj)
    try:
        total = len(ps) * run.cycles * mode.views
        with progress_bar(f"capturing {mode.views} views", total, enabled=not (run.quiet or run.json_)) as advance:
            last = [0]  # frames of the current view so far (each view counts from 1)

            def prog(k, n):
                advance(n - last[0] if n >= last[0] else n)
                last[0] = n
            views = capture_views(proj, cam, stage, positions, seq, out, progress=prog)
        desc = stage.describe()
    finally:
        stage.close()
    names = [v.name for v in views]
    angles = [v.position for v in views]
    extra: list[dict] = [{"angle_deg": a} for a in angles]
    virtual = spec.backend == "virtual"
    if isinstance(stage, VirtualStage):  # the simulator's truth beside what the poses say
        T0 = views[0].transform
        for e, v in zip(extra, views):
            e["true_matrix"] = (T0 @ np.linalg.inv(v.transform)).tolist()
        for n in names:
            stage.rig.save(out / n / "rig.json")
        write_spheres(out, stage.home_scene)
    if mode.stage_axis is not None:
        from fringe3d.multiview.axis import read_axis, turntable_poses  # heavy (scipy.spatial)

        axis, point = read_axis(mode.stage_axis)
        matrices = turntable_poses(axis, point, angles)
        source = f"turntable axis {mode.stage_axis}"
        desc = {**desc, "calibrated_axis": axis.tolist(), "calibrated_point_mm": point.tolist(),
                "axis_file": str(mode.stage_axis)}
    elif virtual:
        matrices = np.stack([np.asarray(e["true_matrix"]) for e in extra])
        source = "the virtual stage's own axis (the simulator's truth)"
    else:
        matrices = None
        source = "none: stage angles only (calibrate the axis with fringe3d calibrate-axis, then capture with " \
                 "--stage-axis)"
    from fringe3d.multiview.poses import write_poses  # heavy (its package brings open3d, 1.5 s)

    poses = write_poses(out / "poses.json", names, matrices, extra=extra,
                        stage={**desc, "step_deg": float(positions[1] - positions[0]), "angles_deg": angles})
    return {"output": str(out), "views": [str(out / n) for n in names], "angles_deg": angles,
            "frames": int(sum(v.result.received for v in views)), "poses": str(poses), "poses_from": source}
