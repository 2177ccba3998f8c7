"""Opening a stage from its spec (``grbl:PORT?...``): the backends a multi-view capture can drive."""
from __future__ import annotations

from .base import DeviceSpec, check_unknown_options, option
from .grbl import GrblStage
from .stage import Stage

#: Stage backends: the simulator's turntable and a GRBL controller's rotary axis.
STAGE_BACKENDS = ("virtual", "grbl")


def open_stage(spec) -> Stage:
    """Open a real stage from a spec.

    Parameters
    ----------
    spec : str or DeviceSpec
        ``grbl:PORT[?axis=A&baud=115200&feed=F&scale=1&timeout=S&step=DEG]``
        (:class:`fringe3d.devices.grbl.GrblStage`; ``step`` is the capture's, not the stage's).

    Returns
    -------
    Stage
        The open stage (close it when done).

    The ``virtual`` stage is opened by :func:`fringe3d.sim.turntable.open_virtual_stage` (the
    command layer routes it there; devices do not import the simulator).
    """
    spec = spec if isinstance(spec, DeviceSpec) else DeviceSpec.parse(spec)
    if spec.backend == "grbl":
        check_unknown_options(spec, {"axis", "baud", "feed", "scale", "timeout", "step"})
        if not spec.ident:
            raise ValueError("grbl stage: give the serial port, e.g. grbl:/dev/ttyUSB0")
        return GrblStage(spec.ident, axis=option(spec.options, "axis", "X"),
                         baud=option(spec.options, "baud", 115200, int),
                         feed=option(spec.options, "feed", None, float),
                         scale=option(spec.options, "scale", 1.0, float),
                         timeout=option(spec.options, "timeout", 60.0, float))
    raise ValueError(f"unknown stage backend {spec.backend!r}; expected one of {', '.join(STAGE_BACKENDS)}")
