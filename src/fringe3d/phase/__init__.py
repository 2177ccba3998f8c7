"""Wrapped phase from fringe images: phase shifting (psp), Fourier transform (ftp), quality masks."""
from fringe3d.phase.ftp import detect_carrier, ftp_phase, modified_ftp_phase
from fringe3d.phase.psp import PhaseResult, three_step, wrapped_phase, wrapped_phase_reference
from fringe3d.phase.quality import FrameQualityWarning, validity_mask

__all__ = ["FrameQualityWarning", "PhaseResult", "detect_carrier", "ftp_phase", "modified_ftp_phase", "three_step",
           "validity_mask", "wrapped_phase", "wrapped_phase_reference"]
