"""Options of ``decode`` and ``reconstruct`` that switch the edge and mixed-pixel masking."""
from __future__ import annotations

import typer

EDGE_MASK_HELP = ("Mask edge and mixed pixels (projector-border band, multi-frequency disagreement, phase-gradient "
                  "jumps, modulation drops); the reasons are the bits of quality maps. --no-edge-mask keeps only "
                  "the modulation/saturation mask.")
EDGE_MARGIN_HELP = ("Width of the masked band at the projector's border, projector pixels "
                    "(default 2 + twice the blur estimated from the fringe periods' modulation).")


def edge_mask_option() -> bool:
    """``--edge-mask/--no-edge-mask`` (a typer option default)."""
    return typer.Option(True, "--edge-mask/--no-edge-mask", help=EDGE_MASK_HELP)


def edge_margin_option() -> float | None:
    """``--edge-margin`` (a typer option default)."""
    return typer.Option(None, "--edge-margin", help=EDGE_MARGIN_HELP)
