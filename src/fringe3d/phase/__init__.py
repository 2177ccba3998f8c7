"""Wrapped phase from fringe images: phase shifting (psp), Fourier transform (ftp), quality masks."""
from fringe3d.phase.psp import PhaseResult, three_step, wrapped_phase, wrapped_phase_reference

__all__ = ["PhaseResult", "three_step", "wrapped_phase", "wrapped_phase_reference"]
