"""Reconstruction: absolute phase -> organized 3D point maps (Eq. 2.37-2.38, 3.3, 4.13).

* :mod:`.triangulate` - least squares (:func:`triangulate`) and the fast per-pixel closed form
  (:class:`Triangulator`), pinhole and telecentric rigs.
* :mod:`.depth` - depth maps, projector coordinates from decoded phase, points from a decode.
* :class:`FastThreeStep` (in :mod:`.triangulate`) - the superfast fused kernel: three frames
  -> wrapped phase -> geometric-constraint order -> point map, one pass.
* :mod:`.sequence` - many-frame captures -> one 3D frame per cycle / window (imported lazily).
"""
from .depth import depth_map, points_from_decoded, projector_coordinates
from .triangulate import FastThreeStep, Triangulator, triangulate

__all__ = ["FastThreeStep", "Triangulator", "triangulate", "depth_map", "points_from_decoded", "projector_coordinates"]
