"""fringe3d: superfast, high-accuracy 3D shape measurement with digital fringe projection.

Implements B. Li, *Superfast 3D shape measurement with application to flapping wing
mechanics analysis* (Purdue, 2017): fringe patterns, phase retrieval and unwrapping,
calibration, triangulation, motion-robust methods, wing strain, and a virtual rig.
"""
__version__ = "0.1.0"
