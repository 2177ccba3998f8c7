"""``--compensate`` and ``--response``: the projector-nonlinearity options of ``decode``,
``reconstruct`` and ``import`` (one definition, one resolution; issue 25)."""
from __future__ import annotations

from pathlib import Path

import typer

from fringe3d.commands.checks import check_choice
from fringe3d.decode.compensation import COMPENSATIONS
from fringe3d.decode.self_calibration import check_compensation
from fringe3d.optics import Rig
from fringe3d.patterns.manifest import PatternSet
from fringe3d.radiometry import ResponseLUT, load_response, rig_response

COMPENSATE_HELP = ("Correct the phase error of a nonlinear projector: harmonic (estimated from the capture itself; "
                   "groups of 4 or more equal steps), disagreement (estimated from two frequencies of the same 3 or "
                   "more equal steps; multi-frequency captures) or response (the grey-ramp response of --response, "
                   "else the one kept in the rig/calibration file by fringe3d response).")
RESPONSE_HELP = ("gamma.json from fringe3d capture --response (or --gamma): the projector's measured response, "
                 "for --compensate response (implies it; overrides the rig's).")


def compensate_option() -> str | None:
    """``--compensate`` (a typer option default)."""
    return typer.Option(None, "--compensate", help=COMPENSATE_HELP)


def response_option() -> Path | None:
    """``--response`` (a typer option default)."""
    return typer.Option(None, "--response", help=RESPONSE_HELP)


def resolve_compensation(compensate: str | None, response: Path | None,
                         rig: Rig | None = None) -> tuple[str | None, ResponseLUT | None]:
    """The compensation to apply and the response it uses, checked before anything is written.

    ``--response`` implies ``--compensate response``; ``--compensate response`` without it uses
    the rig's ``projector_response``. ``ValueError`` naming the flags when neither gives one.
    """
    check_choice(compensate, "--compensate", COMPENSATIONS)
    if compensate is None and response is not None:
        compensate = "response"
    if response is not None:
        return compensate, load_response(response)
    lut = rig_response(rig) if rig is not None else None
    if compensate == "response" and lut is None:
        where = "the calibration has no projector response" if rig is not None else "no --calibration/--rig was given"
        raise ValueError("--compensate response needs --response gamma.json (fringe3d capture --response writes it) "
                         "or a rig/calibration file holding the response (fringe3d response gamma.json -c "
                         f"CALIBRATION -o OUT.json); {where}")
    return compensate, lut if compensate == "response" else None


def check_plans_for(patterns: PatternSet, compensate: str | None) -> None:
    """``--compensate disagreement`` on plans without two frequencies of the same equal steps:
    ``ValueError`` in the flag's words, before anything is written."""
    try:
        check_compensation(patterns, compensate)
    except ValueError as e:
        raise ValueError(str(e).replace("compensate='disagreement'", "--compensate disagreement")) from None
