"""Optical models (Eq. 2.8-2.18, 2.26, 3.1-3.3): pinhole devices with Brown distortion, the telecentric camera,
camera-projector rigs, and projector defocus (OTF/PSF models).

Typical use::

    from fringe3d.optics import Rig
    rig = Rig.load("rig.json")
    uv = rig.projector.project(points)               # (N, 3) -> (N, 2) projector pixels
"""
from .defocus import blur_pattern, defocus_size_at, gaussian_otf, hopkins_otf, otf, psf_kernel
from .distortion import distort, undistort
from .pinhole import PinholeDevice, intrinsics
from .rig import Rig
from .telecentric import TelecentricCamera

__all__ = ["PinholeDevice", "TelecentricCamera", "Rig", "intrinsics", "distort", "undistort", "blur_pattern",
           "defocus_size_at", "gaussian_otf", "hopkins_otf", "otf", "psf_kernel"]
