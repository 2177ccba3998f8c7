"""The virtual camera-projector rig: scenes, renderer, noise, motion and ground truth.

Main entry points: :func:`render` (scene + rig + patterns -> frames, :class:`Truth`),
:class:`RenderSettings`, :mod:`presets` (``presets.get("macro")``) and
:func:`simulate_capture` (writes a capture folder with ``truth/`` and ``rig.json``).

The modules, bottom to top: :mod:`.hits` (the hit record) -> :mod:`.scene_object` (the
:class:`SceneObject` protocol and the posed base class) -> :mod:`.primitives`, :mod:`.mesh`,
:mod:`.sculpture`, :mod:`.wing`, :mod:`.board`, :mod:`.square_board` (the objects) -> :mod:`.scene` (:class:`Scene`)
-> :mod:`.catalog`, :mod:`.scene_file` (ready-made and stored scenes); the renderer
:mod:`.render` chains :mod:`.rays` (camera rays, culled casts, shadow test) ->
:mod:`.geometry` (per-pixel geometry of one instant) -> :mod:`.projector_sampling` ->
:mod:`.radiometry` -> :mod:`.noise` (the sensor) and assembles :mod:`.truth`.
"""
from . import presets
from .hits import Hit
from .mesh import Mesh
from .motion import RigidMotion, falling
from .primitives import Box, Plane, Sphere
from .render import render
from .scene import Scene
from .scene_file import load_scene, save_scene
from .scene_object import PosedObject, SceneObject
from .sculpture import HeightField, sculpture
from .settings import RenderChanges, RenderSettings
from .simulate import make_patterns, make_scene, named_scene, simulate_capture
from .truth import Truth
from .wing import Wing, WingBeat, WingDots, WingShape

__all__ = ["Box", "HeightField", "Hit", "Mesh", "Plane", "PosedObject", "RenderChanges", "RenderSettings",
           "RigidMotion", "Scene", "SceneObject", "Sphere", "Truth", "Wing", "WingBeat", "WingDots", "WingShape",
           "falling", "load_scene", "make_patterns", "make_scene", "named_scene", "presets", "render", "save_scene",
           "sculpture", "simulate_capture"]
