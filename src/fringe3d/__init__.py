"""fringe3d: superfast, high-accuracy 3D shape measurement with digital fringe projection.

Implements B. Li, *Superfast 3D shape measurement with application to flapping wing
mechanics analysis* (Purdue, 2017): fringe patterns, phase retrieval and unwrapping,
calibration, triangulation, motion-robust methods, wing strain, and a virtual rig.

The main steps are available at the top level and imported on first use (PEP 562), so
``import fringe3d`` stays cheap::

    import fringe3d
    r = fringe3d.reconstruct_capture("cap", "cap/rig.json")
    r.save_ply("cap.ply")

One function per command of the same idea:

* ``decode_frames(frames, patterns)``: one cycle to absolute phase (``fringe3d decode``);
* ``reconstruct_capture(folder, calibration)``: a capture folder to points (``fringe3d reconstruct``);
* ``evaluate_points(points, truth)``: accuracy figures in mm (``fringe3d evaluate``);
* ``measure_strain(sequence, anchors, out)``: wing bending strain (``fringe3d strain``);
* ``write_report(folder)``: the HTML report of an output folder (``fringe3d report``).

The functions carry verb-noun names because ``fringe3d.decode``, ``fringe3d.report`` … are the
sub-packages (a sub-package and a function cannot share a name: importing the sub-package
rebinds it); the sub-packages stay reachable as attributes (``fringe3d.decode.decode``) but are
not part of ``__all__``.
"""
import importlib as _importlib
from importlib.metadata import version as _version

__version__ = _version("fringe3d")  # the one version source is pyproject.toml

#: Public name -> (module that defines it, attribute there) (imported lazily by :func:`__getattr__`).
_LAZY: dict[str, tuple[str, str]] = {
    # patterns
    "PatternSet": ("fringe3d.patterns.manifest", "PatternSet"),
    # optics
    "Rig": ("fringe3d.optics", "Rig"),
    # io
    "read_capture": ("fringe3d.io.capture", "read_capture"),
    "write_capture": ("fringe3d.io.capture", "write_capture"),
    # decode / reconstruct / evaluate / strain / report
    "decode_frames": ("fringe3d.decode.decoder", "decode"),
    "triangulate": ("fringe3d.reconstruct.triangulate", "triangulate"),
    "evaluate_points": ("fringe3d.analyze.evaluation", "evaluate_points"),
    "measure_strain": ("fringe3d.analyze.wing_strain", "run_strain"),
    "write_report": ("fringe3d.report.html", "write_report"),
    # calibrate
    "CircleBoard": ("fringe3d.calibrate", "CircleBoard"),
    "Calibration": ("fringe3d.calibrate", "Calibration"),
    "calibrate_session": ("fringe3d.calibrate", "calibrate_session"),
    "load_calibration": ("fringe3d.calibrate", "load_calibration"),
    # pipeline
    "reconstruct_capture": ("fringe3d.pipeline", "reconstruct_capture"),
    "Reconstruction": ("fringe3d.pipeline", "Reconstruction"),
    # sim
    "render": ("fringe3d.sim", "render"),
    "RenderSettings": ("fringe3d.sim", "RenderSettings"),
    "RenderChanges": ("fringe3d.sim", "RenderChanges"),
    "simulate_capture": ("fringe3d.sim", "simulate_capture"),
    "simulate_session": ("fringe3d.sim.calibration_session", "simulate_session"),
}

#: Sub-packages reachable as attributes (``fringe3d.decode.decode``, ``fringe3d.pattern_sets``
#: is ``fringe3d.patterns.sets``), imported on first use; not in ``__all__``.
_MODULES = {name: f"fringe3d.{name}" for name in (
    "analyze", "calibrate", "cluster", "decode", "devices", "experiments", "gpu", "io", "optics",
    "patterns", "phase", "radiometry", "reconstruct", "report", "sim", "unwrap", "utils")}
_MODULES["pattern_sets"] = "fringe3d.patterns.sets"

__all__ = ["__version__", *_LAZY]


def __getattr__(name: str):
    if name in _LAZY:
        module, attr = _LAZY[name]
        value = getattr(_importlib.import_module(module), attr)
    elif name in _MODULES:
        value = _importlib.import_module(_MODULES[name])
    else:
        raise AttributeError(f"module 'fringe3d' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """The public names (``__all__``), the sub-packages and the module's dunders; no helper."""
    dunders = {n for n in globals() if n.startswith("__") and n.endswith("__")}
    return sorted(set(__all__) | set(_MODULES) | dunders)
