"""Decode every pattern cycle of a capture into an output folder, resumably.

One cycle (:func:`fringe3d.decode.decode`, Eq. 2.3-2.13 and the chosen unwrapping) is one
:class:`~fringe3d.decode.result.Decoded` saved in ``OUT`` (one cycle) or ``OUT/cycle_NNNNN``;
an interrupted run resumes from the cycles whose summary (written last) exists.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from fringe3d.decode.decoder import decode
from fringe3d.decode.options import DecodeOptions
from fringe3d.decode.result import SUMMARY_NAME
from fringe3d.optics import Rig
from fringe3d.patterns.manifest import PatternSet
from fringe3d.utils.console import progress_bar
from fringe3d.utils.jsonfile import read_json
from fringe3d.utils.output_folder import OutputGuard, open_output


def decode_capture(frames: Sequence[np.ndarray] | np.ndarray, patterns: PatternSet, out: Path, *,
                   rig: Rig | None = None, options: DecodeOptions | None = None, cycles: int = 1,
                   guard: OutputGuard | None = None, allow_empty: bool = False, name: str = "the capture",
                   on_cycle: Callable[[Path, dict], None] | None = None) -> list[dict]:
    """Decode the first ``cycles`` pattern cycles of ``frames`` into the guarded folder ``out``.

    Parameters
    ----------
    frames : sequence of ndarray
        The captured frames, ``cycles * len(patterns)`` at least, each ``(H, W)``; a lazily read
        source (a camera file) is read one cycle at a time.
    patterns : PatternSet
        The manifest of one cycle.
    out : Path
        Output folder (:func:`fringe3d.utils.output_folder.open_output`); with ``cycles > 1`` one
        ``cycle_NNNNN`` sub-folder per cycle, and the run is resumable.
    rig : Rig, optional
        Calibrated rig, for geometric and hybrid unwrapping.
    options : DecodeOptions, optional
        Decoding options (default ``DecodeOptions()``).
    cycles : int
        Number of cycles to decode.
    guard : OutputGuard, optional
        How ``out`` is guarded (:class:`fringe3d.utils.output_folder.OutputGuard`): whether an
        existing, different output is replaced, and the input files and options fingerprinted
        into the output (a resumed run must have the same); default ``OutputGuard()``.
    allow_empty : bool
        Write a cycle in which no pixel is valid instead of raising.
    name : str
        How error messages name the capture (its folder or file).
    on_cycle : callable, optional
        ``on_cycle(folder, summary)`` after each decoded cycle is saved: writes what the caller
        adds to the cycle's folder (e.g. an exposure bracket's index map) and amends its summary.

    Returns
    -------
    list of dict
        One summary per cycle (:meth:`Decoded.summary` plus ``cycle`` and ``folder``; a cycle read
        back from a resumed run also has ``resumed: True``).

    Raises
    ------
    ValueError
        A cycle has no valid pixel and ``allow_empty`` is False (nothing of it is written).
    """
    options = options if options is not None else DecodeOptions()
    guard = guard if guard is not None else OutputGuard()
    length = len(patterns)
    results: list[dict] = []
    with open_output(out, overwrite=guard.overwrite, inputs=list(guard.inputs), options=dict(guard.fingerprint or {}),
                     resumable=cycles > 1) as o, \
            progress_bar("decoding", cycles, enabled=cycles > 1) as advance:
        for c in range(cycles):
            folder = o.path if cycles == 1 else o.path / f"cycle_{c:05d}"
            if o.resumed and (folder / SUMMARY_NAME).is_file():  # written last by Decoded.save: this cycle is done
                results.append({**read_json(folder / SUMMARY_NAME, "decode summary"), "cycle": c,
                                "folder": str(o.final_paths(folder)), "resumed": True})
                advance()
                continue
            dec = decode(np.asarray(frames[c * length:(c + 1) * length]), patterns, rig=rig, options=options)
            why = dec.empty_reason()
            if why and not allow_empty:
                raise ValueError(f"{name}" + (f" cycle {c}" if cycles > 1 else "") + f": {why}. Nothing "
                                 "was written (pass `allow_empty=True` to write it anyway)")
            dec.save(folder)
            s = dec.summary()
            if on_cycle is not None:
                on_cycle(folder, s)
            s["cycle"], s["folder"] = c, str(o.final_paths(folder))
            results.append(s)
            advance()
    return results
