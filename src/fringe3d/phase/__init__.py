"""Wrapped phase from fringe images (Eq. 1.4, 2.4, 4.1-4.7): phase shifting, Fourier transform profilometry,
validity masks, and the helpers every layer above uses (the frame-stack check, bilinear
sampling).

Typical use::

    from fringe3d.phase import wrapped_phase, validity_mask
    res = wrapped_phase(frames)                      # (N, H, W) -> phase, average, modulation
    ok = validity_mask(res.average, res.modulation, frames)
"""
from fringe3d.phase.frames import as_frame_stack
from fringe3d.phase.ftp import (FTPResult, bandpass_window, detect_carrier, ftp_analysis, ftp_phase,
                                modified_ftp_phase)
from fringe3d.phase.psp import PhaseResult, default_shifts, lsq_coefficients, three_step, wrapped_phase
from fringe3d.phase.quality import FrameQualityWarning, check_frames, validity_mask
from fringe3d.phase.sampling import sample_bilinear

__all__ = ["FTPResult", "FrameQualityWarning", "PhaseResult", "as_frame_stack", "bandpass_window", "check_frames",
           "default_shifts", "detect_carrier", "ftp_analysis", "ftp_phase", "lsq_coefficients", "modified_ftp_phase",
           "sample_bilinear", "three_step", "validity_mask", "wrapped_phase"]
