"""The :class:`Scene`: the simulator's objects composed into one ray-traceable world.

>>> import numpy as np
>>> from fringe3d.sim.primitives import Plane, Sphere
>>> scene = Scene([Plane((0, 0, 200), (0, 0, -1)), Sphere((0, 0, 100), 10)])
>>> scene.intersect(np.zeros(3), np.array([[0.0, 0.0, 1.0], [0.0, 0.5, 1.0]])).object_id.tolist()
[1, 0]
"""
from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from .hits import Hit, as_rays, is_fresh_hit
from .scene_object import SceneObject, SupportsTruthFields, check_albedo


class Scene:
    """A list of objects; :meth:`intersect` keeps the nearest hit and sets ``object_id`` to the
    object's index in ``objects``. ``ambient`` (in [0, 1]) is the scene's ambient light level
    relative to the projector's full white, for the renderer."""

    def __init__(self, objects: Iterable[SceneObject], ambient: float = 0.0, name: str = "scene"):
        self.objects: list[SceneObject] = list(objects)
        if not self.objects:
            raise ValueError("a scene needs at least one object")
        for i, ob in enumerate(self.objects):
            if not isinstance(ob, SceneObject):
                raise ValueError(f"scene object {i} ({type(ob).__name__}) has no intersect method "
                                 "(a scene object implements fringe3d.sim.scene_object.SceneObject)")
        self.ambient: float = check_albedo(ambient, "ambient")
        self.name: str = name

    def __len__(self) -> int:
        return len(self.objects)

    def __getitem__(self, i: int) -> SceneObject:
        return self.objects[i]

    @property
    def moving(self) -> bool:
        """True if any object moves or deforms over time (render each frame at its time)."""
        return any(ob.moving for ob in self.objects)

    def to_dict(self) -> dict:
        """The scene as a scene-file dictionary (:func:`fringe3d.sim.scene_file.save_scene`)."""
        return {"format": "fringe3d-scene", "version": 1, "name": self.name, "ambient": self.ambient,
                "objects": [ob.to_dict() for ob in self.objects]}

    def intersect(self, origins: np.ndarray, dirs: np.ndarray, time: float = 0.0) -> Hit:
        """Nearest hit over all objects (shapes and conventions: :mod:`fringe3d.sim.hits`)."""
        o, d = as_rays(origins, dirs)
        best = None
        for i, ob in enumerate(self.objects):
            h = ob.intersect(o, d, time)
            if best is None and is_fresh_hit(h, len(d)):
                best = h  # the first object's own record, relabelled (object 0): no copy
                best.object_id[best.object_id >= 0] = 0
                continue
            if best is None:
                best = Hit.miss(len(d))
            best.merge_nearer(h, i)
        assert best is not None  # a scene has at least one object
        return best

    def truth_fields(self, hit: Hit, time: float = 0.0) -> dict:
        """Extra per-ray ground truth of the rays of ``hit`` (a cast of this scene) from the
        objects that provide ``truth_fields(uv, time)``
        (:class:`~fringe3d.sim.scene_object.SupportsTruthFields`; the wing: curvature, principal
        curvature/direction, bending strain, Eq. 6.11-6.20). Returns ``{name: (N, ...) float32}``
        with NaN on rays that hit other objects or nothing; an object out of view still gives
        its fields (all NaN); ``{}`` when no object provides extra truth."""
        n = len(hit)
        out: dict = {}
        for i, ob in enumerate(self.objects):
            if not isinstance(ob, SupportsTruthFields):
                continue
            rows = np.flatnonzero(hit.object_id == i)
            uv = hit.material_uv[rows] if rows.size else np.zeros((1, 2))  # out of view: still its fields
            fields = ob.truth_fields(uv, time)
            for name, val in fields.items():
                if name not in out:
                    out[name] = np.full((n,) + np.shape(val)[1:], np.nan, np.float32)
                if rows.size:
                    out[name][rows] = val
        return out


def as_scene(scene: Scene | SceneObject) -> Scene:
    """``scene`` itself, or a one-object :class:`Scene` around a bare scene object."""
    return scene if isinstance(scene, Scene) else Scene([scene])
