"""Per-rig precomputation, owned by whoever reconstructs with the rig.

:class:`RigGeometry` holds the arrays that depend only on a rig (and a few scalars): the
camera rays, built once for every map and triangulator below
(:func:`fringe3d.optics.rays.camera_planes`), the minimum phase maps of the geometric constraint
keyed by ``(z_min, period, angle)`` (Eq. 4.14-4.19,
:func:`fringe3d.unwrap.geometric.cached_minimum_phase`), the closed-form triangulators keyed by
fringe angle (Eq. 2.37, :func:`fringe3d.reconstruct.depth.triangulator_for`).
The engine (:class:`fringe3d.reconstruct.frame.FrameReconstructor`) builds one and passes it
down to ``decode(..., geometry=...)``, the plan checks and triangulation; a caller without an
engine gets a fresh one per call. No module-level cache holds a rig: the entries live exactly as
long as the :class:`RigGeometry` that owns them.

The layers above (and :mod:`fringe3d.optics.rays`) fill the entries (this module knows nothing
of rays, unwrapping or triangulation):
each entry is built once by :meth:`RigGeometry.memo` from a key and a builder function.
"""
from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import Any, TypeVar

from fringe3d.optics.rig import Rig

T = TypeVar("T")


class RigGeometry:
    """The precomputed geometry of one rig: entries built once, on first use.

    Parameters
    ----------
    rig : fringe3d.optics.Rig
        The calibrated rig; held for the object's lifetime (its owner holds the rig anyway).

    Attributes
    ----------
    rig : Rig
    built : dict
        Number of times each entry kind (the first element of a key) was built; an entry is
        built once per key.
    """

    def __init__(self, rig: Rig):
        self.rig = rig
        self._entries: dict[Hashable, Any] = {}
        self.built: dict[Hashable, int] = {}

    def memo(self, key: tuple, build: Callable[[], T]) -> T:
        """The entry of ``key`` (a tuple whose first element names the kind, e.g.
        ``("minimum_phase", z_min, period, angle)``), calling ``build()`` the first time."""
        if key not in self._entries:
            self._entries[key] = build()
            self.built[key[0]] = self.built.get(key[0], 0) + 1
        return self._entries[key]

    @classmethod
    def of(cls, rig: Rig, geometry: RigGeometry | None = None) -> RigGeometry:
        """``geometry`` when given (checked to belong to ``rig``), else a fresh one of ``rig``."""
        if geometry is None:
            return cls(rig)
        if geometry.rig is not rig:
            raise ValueError("geometry was built for another rig than the one passed (pass the RigGeometry of "
                             "this rig, or none)")
        return geometry

    def __repr__(self) -> str:
        return f"RigGeometry({len(self._entries)} entries)"


__all__ = ["RigGeometry"]
