"""Whole objects from several views: poses, registration, fusion and meshing.

:mod:`.poses` (the poses file), :mod:`.axis` (turntable-axis calibration), :mod:`.views` (reading
reconstructed views), :mod:`.register` (coarse, fine and pose-graph registration on Open3D),
:mod:`.fuse` (σ-weighted voxel fusion), :mod:`.mesh` (screened Poisson meshing), :mod:`.merge`
(the whole chain, :func:`merge_views`).
"""
from __future__ import annotations

try:
    import open3d  # noqa: F401  (every step runs on it)
except ImportError as e:  # pragma: no cover - the test extra installs it
    raise ImportError("fringe3d.multiview (fringe3d merge) needs open3d: pip install 'fringe3d[open3d]'") from e
