"""Phase unwrapping: pure array algorithms (no manifest, no decoding context).

* temporal: :func:`hierarchical`, :func:`heterodyne`, :func:`gray_code_order` (+ :func:`code_centers`),
  the fused :func:`three_frequency_decode` (Eq. 1.5);
* geometric constraint: :func:`minimum_phase`, :func:`geometric_unwrap`, :func:`depth_limit`
  (Eq. 4.14-4.21);
* spatial per object: :func:`unwrap_objects`, :func:`segment_objects`, :func:`foreground_mask`;
* histogram and hybrid fringe-order shifts: :func:`histogram_unwrap`, :func:`hybrid_phase`,
  :func:`hybrid_unwrap` (Eq. 5.12-5.15).

The manifest-driven methods that combine them are in :mod:`fringe3d.decode`.
"""
from fringe3d.unwrap.geometric import (MinimumPhase, cached_minimum_phase, check_depth_range, check_wrap_around,
                                       depth_limit, fringe_order, geometric_unwrap, minimum_phase, propose_z_min)
from fringe3d.unwrap.histogram import (OrderVote, apply_order_shift, fringe_order_difference, histogram_unwrap,
                                       minimum_phase_orders, mode_of_orders)
from fringe3d.unwrap.hybrid import (HybridResult, HybridSettings, carrier_from_minimum_phase, ftp_group_phase,
                                    hybrid_phase, hybrid_unwrap)
from fringe3d.unwrap.segmentation import foreground_mask, match_objects, segment_objects, shift_image
from fringe3d.unwrap.spatial import unwrap_objects
from fringe3d.unwrap.temporal import (MAX_CODE_RESIDUAL, CodeStripes, CodeUnwrapped, FusedResult, OrderedPhase,
                                      beat_chain, coarse_window, code_centers, code_stripes, gray_code_order,
                                      heterodyne, hierarchical, three_frequency_decode)

__all__ = ["MAX_CODE_RESIDUAL", "CodeStripes", "CodeUnwrapped", "FusedResult", "HybridResult", "HybridSettings",
           "MinimumPhase",
           "OrderVote", "OrderedPhase",
           "apply_order_shift", "beat_chain", "cached_minimum_phase", "carrier_from_minimum_phase",
           "check_depth_range", "check_wrap_around", "coarse_window", "code_centers", "code_stripes", "depth_limit",
           "foreground_mask", "fringe_order", "fringe_order_difference", "ftp_group_phase",
           "geometric_unwrap", "gray_code_order", "heterodyne", "hierarchical", "histogram_unwrap", "hybrid_phase",
           "hybrid_unwrap", "match_objects", "minimum_phase", "minimum_phase_orders", "mode_of_orders",
           "propose_z_min", "segment_objects", "shift_image", "three_frequency_decode", "unwrap_objects"]
