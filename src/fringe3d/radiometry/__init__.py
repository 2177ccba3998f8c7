"""Radiometry: the projector's response and the phase error it causes, for captures already taken.

* :mod:`.response`: a monotone response LUT from a grey ramp, its inverse, linearised frames;
* :mod:`.phase_error`: the phase-error LUT indexed by wrapped phase (Zhang & Yau 2007);
* :mod:`.harmonics`: the self-calibrating harmonic model for N >= 4 steps;
* :mod:`.disagreement`: the same from two frequencies' disagreement (any N, Xing & Guo 2018);
* :mod:`.rig_response`: the response kept with the rig (rig file version 2);
* :mod:`.diagnostic`: "your projector is nonlinear, this is the ripple, this is the fix".
"""
from .diagnostic import NonlinearityReport, diagnose
from .disagreement import disagreement_lut
from .harmonics import HarmonicEstimate, estimate_gamma, harmonic_lut
from .phase_error import PhaseErrorLUT, lut_from_reference, lut_from_response
from .rig_response import rig_response, with_response
from .response import (ResponseLUT, fit_response, linearise_frames, load_response, power_law, predistort,
                       response_phase)

__all__ = ["HarmonicEstimate", "NonlinearityReport", "PhaseErrorLUT", "ResponseLUT", "diagnose", "disagreement_lut",
           "estimate_gamma", "fit_response", "harmonic_lut", "linearise_frames", "load_response", "lut_from_reference",
           "lut_from_response", "power_law", "predistort", "response_phase", "rig_response", "with_response"]
