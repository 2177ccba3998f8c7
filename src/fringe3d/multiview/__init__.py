"""Whole objects from several views: poses, registration, fusion and meshing.

:mod:`.poses` (the poses file), :mod:`.axis` (turntable-axis calibration), :mod:`.views` (reading
reconstructed views), :mod:`.register` (coarse, fine and pose-graph registration on Open3D),
:mod:`.fuse` (σ-weighted voxel fusion), :mod:`.mesh` (screened Poisson meshing), :mod:`.merge`
(the whole chain, :func:`merge_views`).
"""
