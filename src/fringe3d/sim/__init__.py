"""The virtual camera-projector rig: scenes, renderer, noise, motion and ground truth.

Main entry points: :func:`render` (scene + rig + patterns -> frames, :class:`Truth`),
:class:`RenderSettings`, :mod:`presets` (``presets.get("macro")``) and
:func:`simulate_capture` (writes a capture folder with ``truth/`` and ``rig.json``).
"""
from .render import render
from .settings import RenderSettings
from .truth import Truth


def simulate_capture(*args, **kwargs):
    """Write a simulated capture folder; see :func:`fringe3d.sim.simulate.simulate_capture`."""
    from .simulate import simulate_capture as _simulate_capture
    return _simulate_capture(*args, **kwargs)


__all__ = ["render", "RenderSettings", "Truth", "simulate_capture"]
