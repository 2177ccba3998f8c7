"""fringe3d's warning classes, so that users can filter and tests can assert them.

Library code never prints: it calls ``warnings.warn(message, SomeWarning, stacklevel=2)``.
The command layer shows warnings on stderr. Filter all of them with
``warnings.simplefilter("ignore", fringe3d.utils.warning_types.Fringe3DWarning)``.
"""
from __future__ import annotations


class Fringe3DWarning(UserWarning):
    """Base class of every warning fringe3d issues."""


class DepthRangeWarning(Fringe3DWarning):
    """The scene leaves the depth range a method can unwrap (e.g. geometric constraint, §4.4)."""


class DataQualityWarning(Fringe3DWarning):
    """Input data are poor: few valid pixels, dark or saturated frames, low modulation."""


class CalibrationWarning(Fringe3DWarning):
    """A calibration pose or point was skipped, or a calibration figure is suspect."""


class SimulationWarning(Fringe3DWarning):
    """The virtual rig was asked for something it approximates or cannot render exactly."""


class ReconstructionWarning(Fringe3DWarning):
    """Triangulation or a motion/single-shot method dropped or doubted part of the result."""


class AnalysisWarning(Fringe3DWarning):
    """A fit, tracking or strain figure is based on too few points or an ill-posed geometry."""


class UnwrapRangeWarning(Fringe3DWarning):
    """The coarsest (equivalent) unwrapping period is shorter than the projector's coordinate range."""


class DeviceWarning(Fringe3DWarning):
    """A projector or camera setting was adjusted, is unknown, or was not reported by the device."""


class RenamedFieldWarning(Fringe3DWarning, FutureWarning):
    """A file was read through a field's old name (read as the new one; write the file again to
    update it). A :class:`FutureWarning`, so shown by default: the old name goes in a later release."""


class OutputWarning(Fringe3DWarning):
    """An output folder's state was repaired: a dead run's temporaries removed, an unfinished set restarted."""
