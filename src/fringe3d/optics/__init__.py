"""Optical models: pinhole devices with Brown distortion, telecentric camera, rigs, defocus."""
from .distortion import distort, undistort
from .pinhole import PinholeDevice, intrinsics
from .rig import Rig
from .telecentric import TelecentricCamera

__all__ = ["PinholeDevice", "TelecentricCamera", "Rig", "intrinsics", "distort", "undistort"]
