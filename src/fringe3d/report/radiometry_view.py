"""The report's "Projector nonlinearity" section (issue 25): per direction, the diagnostic of
``decoded.json`` (``info.radiometry``: harmonic ratio, the gamma that explains it, the ripple in
rad, projector px and micrometres on the surface, the recommended fix), what a compensation did,
and whether the calibration keeps the projector's measured response."""
from __future__ import annotations

import html

from .discover import FolderContents

DIAGNOSTIC_ROWS = (("nonlinear", "nonlinear projector"), ("harmonic_ratio", "second-harmonic ratio c2/c1"),
                   ("gamma", "gamma that explains it"), ("ripple_order", "ripple (cycles per fringe)"),
                   ("ripple_rad", "ripple amplitude (rad)"), ("ripple_px", "ripple amplitude (projector px)"),
                   ("ripple_um", "ripple amplitude on the surface (um)"))


def _direction_rows(rad: dict) -> list[list]:
    diag = rad.get("diagnostic") or {}
    rows = [[label, diag[key]] for key, label in DIAGNOSTIC_ROWS if diag.get(key) is not None]
    for comp in rad.get("compensation") or []:
        if isinstance(comp, dict):
            done = "applied" if comp.get("applied") else f"not applied ({comp.get('reason', '')})"
            rows.append([f"compensation {comp.get('compensation')} (group {comp.get('group')})", done])
    return rows


def radiometry_parts(c: FolderContents, table) -> list[str]:
    """HTML parts of the section; empty when the folder holds no diagnostic and no response."""
    decoded = c.summaries.get("decoded.json") or {}
    info = decoded.get("info") if isinstance(decoded.get("info"), dict) else {}
    per_dir = info.get("radiometry") if isinstance(info.get("radiometry"), dict) else {}
    rig = (c.calibration or {}).get("rig", c.calibration or {})
    response = rig.get("projector_response") if isinstance(rig, dict) else None
    if not per_dir and not response:
        return []
    parts = ["<h2>Projector nonlinearity</h2>"]
    if response:
        parts.append(f"<p class='muted'>the calibration keeps the projector's measured response "
                     f"({len(response.get('inputs', []))} levels): decoding with the response compensation uses it</p>")
    for d, rad in per_dir.items():
        if not isinstance(rad, dict):
            continue
        parts.append(f"<h3>direction {html.escape(str(d))}</h3>")
        fix = (rad.get("diagnostic") or {}).get("fix")
        if fix:
            parts.append(f"<p class='warn'>{html.escape(fix)}</p>")
        parts.append(table(_direction_rows(rad), ["quantity", "value"], "summary"))
    return parts
