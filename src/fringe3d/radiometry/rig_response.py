"""The projector response kept with the rig (``Rig.projector_response``, rig file version 2).

The grey-ramp response (:func:`fringe3d.radiometry.fit_response`, ``fringe3d capture --gamma``)
is a property of the projector, so it travels in the rig / calibration file from capture to
decode: ``fringe3d decode --compensate response`` uses it when no response file is given.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from fringe3d.optics.rig import Rig

from .response import ResponseLUT


def rig_response(rig: Rig) -> ResponseLUT | None:
    """The rig's projector response as a :class:`ResponseLUT`.

    Parameters
    ----------
    rig : Rig
        A rig, from a calibration or rig file (``projector_response``, optional).

    Returns
    -------
    ResponseLUT or None
        The table, or None when the rig carries no response.
    """
    if rig.projector_response is None:
        return None
    inputs, response = rig.projector_response
    return ResponseLUT(np.asarray(inputs, float), np.asarray(response, float))


def with_response(rig: Rig, response: ResponseLUT) -> Rig:
    """A copy of ``rig`` carrying ``response`` (the table is stored as plain floats).

    Parameters
    ----------
    rig : Rig
        The rig to copy.
    response : ResponseLUT
        The projector's measured response.

    Returns
    -------
    Rig
        The copy, whose file (version 2) keeps the response.
    """
    table = (tuple(float(v) for v in response.inputs), tuple(float(v) for v in response.response))
    return replace(rig, projector_response=table)
