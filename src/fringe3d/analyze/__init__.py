"""Analysis of measured point maps: shape fits and VDI/VDE 2634-2-style accuracy figures
(:mod:`.fits`, :mod:`.vdi`, :mod:`.sections`, :mod:`.evaluation`), geodesics, tracking and
strain of membranes (:mod:`.geodesic`, :mod:`.anchors`, :mod:`.tracking`, :mod:`.strain`,
:mod:`.wing_strain`; dissertation ch. 6)."""
from .anchors import check_anchor, distance_maps, fill_dot_holes, find_anchor_dots, follow_anchors, pair_anchors
from .evaluation import evaluate_points, load_points, truth_errors
from .fits import CircleFit, PlaneFit, SphereFit, fit_circle, fit_plane, fit_sphere, inner_mask, robust_fit
from .geodesic import bezier_geodesic, grid_geodesic, heat_geodesic
from .sections import segments, sphere_sections
from .strain import (LocalShape, StrainResult, TrackingSettings, WingSequence, bending_strain, local_shape,
                     principal_strains, wing_sequence)
from .tracking import TrackResult, track_points
from .vdi import flatness, probing_errors, sphere_spacing
from .wing_strain import StrainSettings, run_strain

__all__ = [
    "fit_plane", "fit_sphere", "fit_circle", "PlaneFit", "SphereFit", "CircleFit", "inner_mask", "robust_fit",
    "probing_errors", "sphere_spacing", "flatness", "sphere_sections", "segments",
    "evaluate_points", "load_points", "truth_errors",
    "bezier_geodesic", "grid_geodesic", "heat_geodesic",
    "find_anchor_dots", "pair_anchors", "check_anchor", "fill_dot_holes", "distance_maps", "follow_anchors",
    "track_points", "TrackResult",
    "local_shape", "LocalShape", "bending_strain", "StrainResult", "principal_strains", "wing_sequence",
    "WingSequence", "TrackingSettings", "run_strain", "StrainSettings",
]
