"""fringe3d: superfast, high-accuracy 3D shape measurement with digital fringe projection.

Implements B. Li, *Superfast 3D shape measurement with application to flapping wing
mechanics analysis* (Purdue, 2017): fringe patterns, phase retrieval and unwrapping,
calibration, triangulation, motion-robust methods, wing strain, and a virtual rig.

The main steps are available at the top level and imported on first use (PEP 562), so
``import fringe3d`` stays cheap::

    import fringe3d
    r = fringe3d.reconstruct_capture("cap", "cap/rig.json")
    r.save_ply("cap.ply")
"""
from __future__ import annotations

import importlib
from importlib.metadata import version as _version

__version__ = _version("fringe3d")  # the one version source is pyproject.toml

#: Public name -> module that defines it (imported lazily by :func:`__getattr__`).
_LAZY = {
    # patterns
    "PatternSet": "fringe3d.patterns.manifest",
    "pattern_sets": "fringe3d.patterns.sets",
    # optics
    "Rig": "fringe3d.optics",
    # io
    "read_capture": "fringe3d.io.capture",
    "write_capture": "fringe3d.io.capture",
    # decode / reconstruct (``fringe3d.decode`` is the decode package: ``fringe3d.decode.decode(frames, patterns)``;
    # a top-level function of that name would be overwritten whenever the package is imported)
    "decode": "fringe3d.decode",
    "triangulate": "fringe3d.reconstruct.triangulate",
    # calibrate
    "CircleBoard": "fringe3d.calibrate",
    "Calibration": "fringe3d.calibrate",
    "calibrate_session": "fringe3d.calibrate",
    "load_calibration": "fringe3d.calibrate",
    # pipeline
    "reconstruct_capture": "fringe3d.pipeline",
    "Reconstruction": "fringe3d.pipeline",
    # sim
    "render": "fringe3d.sim",
    "RenderSettings": "fringe3d.sim",
    "simulate_capture": "fringe3d.sim",
    "simulate_session": "fringe3d.sim.calibration_session",
}
#: Names whose module attribute differs from the public name.
_ATTR = {"pattern_sets": None, "decode": None}

__all__ = ["__version__", *_LAZY]


def __getattr__(name: str):
    if name not in _LAZY:
        raise AttributeError(f"module 'fringe3d' has no attribute {name!r}")
    module = importlib.import_module(_LAZY[name])
    value = module if _ATTR.get(name, name) is None else getattr(module, name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
