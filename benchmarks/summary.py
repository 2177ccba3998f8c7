"""The figures every benchmark reports with ``--json``, the one summary table ``run_all.py`` prints
and the regression rule of ``compare_revisions.py --fail-above`` (pure functions; tested by
``tests/test_benchmarks_table.py``).

A benchmark's JSON object carries ``"figures"``: a list of dicts

``{"group": "decode, 15 frames, 1280x1024", "name": "decode() (whole decoder)", "role": ROLE,
"unit": UNIT, "min": .., "median": .., "max": .., "rounds": N}``

* ``role``: ``"ours"`` (fringe3d as a user runs it), ``"kernel"`` (the fused kernel alone, the
  reference of the "x kernel" column; one per group at most), ``"bound"`` (the plain memory copy
  of the same bytes, timed in the same alternated rounds: the reference of the "x bound" column;
  one per group at most), ``"reference"`` (another named yardstick, e.g. copy + ``np.arctan2``),
  ``"peer"`` (another package doing the same job; ``"status": "not installed"`` and no numbers
  when its venv is missing);
* ``unit``: ``"ms"`` or ``"s"`` (a time: lower is better), a rate ending in ``"/s"`` (higher is
  better) or anything else (``"MB"``: shown, never compared with a kernel or bound);
* ``min`` / ``median`` / ``max`` over ``rounds`` alternated rounds (every case of the group timed
  once per round, in rotating order, so that drift of a shared machine hits every case alike).

Optional ``"groups"``: ``{group: {"scene": str, "wrap_errors": int}}``: the scene a group times
and its count of pixels whose fringe order is wrong against the ground truth (0 for an honest
benchmark: a wrong order is a cheaper pixel for some kernels), printed in the group's heading.

All ratios are of times (a rate r counts as the time 1 / r): "x kernel" = this figure's median
time / the kernel's, "x bound" = / the bound's, "peer" = the fastest installed peer's median time
/ this figure's (how many times faster than the peer).
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable

ROLES = ("bound", "reference", "kernel", "ours", "peer")
#: width of the figure column of the table (longer names are cut)
NAME_WIDTH = 66


def is_time(unit: str) -> bool:
    """Whether a figure in ``unit`` is a time (lower is better)."""
    return unit in ("ms", "s", "us")


def is_rate(unit: str) -> bool:
    """Whether a figure in ``unit`` is a rate (higher is better)."""
    return unit.endswith("/s")


def as_time(value: float | None, unit: str) -> float | None:
    """``value`` as a time in comparable units (rates inverted); None when not a speed figure."""
    if value is None or not (is_time(unit) or is_rate(unit)):
        return None
    if is_rate(unit):
        return 1.0 / value if value > 0 else math.inf
    return value * {"s": 1e3, "ms": 1.0, "us": 1e-3}[unit]


def stats(values: Iterable[float]) -> dict:
    """``{"min", "median", "max", "rounds"}`` of ``values`` (at least one)."""
    v = sorted(float(x) for x in values)
    if not v:
        raise ValueError("stats: no values (at least one round is needed)")
    n = len(v)
    med = v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2])
    return {"min": v[0], "median": med, "max": v[-1], "rounds": n}


def alternated(cases: dict[str, Callable[[], object]], rounds: int, warmup: bool = True) -> dict[str, list[float]]:
    """Wall seconds of every case in ``cases`` over ``rounds`` alternated rounds.

    One warm-up call each (compilation, caches), then per round every case once, the order
    rotated by one case each round (A B C, B C A, C A B, ...), so that a neighbour's load on a
    shared machine hits every case alike.
    """
    names = list(cases)
    if warmup:
        for name in names:
            cases[name]()
    out: dict[str, list[float]] = {n: [] for n in names}
    for r in range(rounds):
        for i in range(len(names)):
            name = names[(r + i) % len(names)]
            t0 = time.perf_counter()
            cases[name]()
            out[name].append(time.perf_counter() - t0)
    return out


def figure(group: str, name: str, role: str, unit: str, values: Iterable[float] | None = None,
           **extra) -> dict:
    """One figure dict (see the module docstring); ``values`` None for a peer not installed."""
    if role not in ROLES:
        raise ValueError(f"figure {name!r}: role {role!r}, expected one of {ROLES}")
    f = {"group": group, "name": name, "role": role, "unit": unit}
    if values is None:
        f.update({"min": None, "median": None, "max": None, "rounds": 0})
        f.setdefault("status", "not installed")
    else:
        f.update(stats(values))
        f["status"] = "ok"
    f.update(extra)
    return f


def timed_figures(group: str, seconds: dict[str, list[float]], roles: dict[str, str], unit: str = "ms",
                  names: dict[str, str] | None = None) -> list[dict]:
    """Figures of :func:`alternated`'s output, in ``unit`` ("ms", or a rate "X/s" for one item per call)."""
    out = []
    for key, ts in seconds.items():
        vals = [1e3 * t for t in ts] if unit == "ms" else [1.0 / t for t in ts] if is_rate(unit) else ts
        out.append(figure(group, (names or {}).get(key, key), roles[key], unit, vals))
    return out


def _fmt(x: float | None) -> str:
    if x is None:
        return "-"
    if x == 0 or 0.01 <= abs(x) < 1e5:
        return f"{x:.3g}" if abs(x) < 100 else f"{x:.0f}"
    return f"{x:.2e}"


def _ratio(x: float | None) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.2f}x"


def table_rows(figures: list[dict]) -> list[dict]:
    """Rows of the summary table: every figure with its ratios to the kernel, the bound and the
    fastest installed peer of its group (see the module docstring), grouped in first-seen order
    and, within a group, ordered bound, reference, kernel, ours, peer."""
    groups: dict[str, list[dict]] = {}
    for f in figures:
        groups.setdefault(f["group"], []).append(f)
    rows = []
    for figs in groups.values():
        def ref(role: str, figs=figs) -> float | None:
            for g in figs:
                if g["role"] == role and g.get("median") is not None:
                    return as_time(g["median"], g["unit"])
            return None
        kernel, bound = ref("kernel"), ref("bound")
        peers = [g for g in figs if g["role"] == "peer"]
        peer_times = [(as_time(g["median"], g["unit"]), g["name"]) for g in peers if g.get("median") is not None]
        fastest_peer = min(peer_times) if peer_times else None
        for f in sorted(figs, key=lambda g: ROLES.index(g["role"])):
            t = as_time(f.get("median"), f["unit"])
            row = {**f, "x_kernel": None, "x_bound": None, "peer": None}
            if t is not None:
                row["x_kernel"] = t / kernel if kernel else None
                row["x_bound"] = t / bound if bound else None
                if f["role"] in ("ours", "kernel"):
                    if fastest_peer is not None:
                        row["peer"] = f"{fastest_peer[0] / t:.1f}x faster than {fastest_peer[1]}"
                    elif peers:
                        row["peer"] = "peer not installed"
            rows.append(row)
    return rows


def format_table(rows: list[dict], groups: dict[str, dict] | None = None, title: str = "") -> str:
    """The summary table as text: one heading line per group (its scene and wrap-error count when
    known), one line per figure."""
    groups = groups or {}
    head = (f"{'figure':<{NAME_WIDTH}}{'unit':>12}{'min':>9}{'median':>9}{'max':>9}{'rounds':>7}"
            f"{'x kernel':>10}{'x bound':>9}  peer")
    lines = [title] if title else []
    lines += [head, "-" * len(head)]
    current = None
    for r in rows:
        if r["group"] != current:
            current = r["group"]
            g = groups.get(current, {})
            extra = []
            if g.get("scene"):
                extra.append(f"scene: {g['scene']}")
            if "wrap_errors" in g:
                extra.append(f"wrap errors: {g['wrap_errors'] if g['wrap_errors'] is not None else 'n/a'}")
            lines.append(f"[{current}]" + (f"  ({'; '.join(extra)})" if extra else ""))
        label = f"  {r['role']}: {r['name']}"
        if r.get("status") not in (None, "ok"):
            lines.append(f"{label[:NAME_WIDTH]:<{NAME_WIDTH}}{r['unit']:>12}  {r['status']}")
            continue
        lines.append(f"{label[:NAME_WIDTH]:<{NAME_WIDTH}}{r['unit']:>12}{_fmt(r['min']):>9}{_fmt(r['median']):>9}{_fmt(r['max']):>9}"
                     f"{r['rounds']:>7}{_ratio(r['x_kernel']):>10}{_ratio(r['x_bound']):>9}  {r['peer'] or ''}")
    return "\n".join(lines)


def figure_key(f: dict) -> str:
    """The name under which ``compare_revisions.py`` matches a figure across revisions."""
    return f"{f['group']} / {f['name']} [{f['unit']}]"


def compare_figures(a: dict[str, list[float]], b: dict[str, list[float]]) -> list[dict]:
    """Rows ``{"figure", "unit", "a", "b", "ratio_b_over_a"}`` (medians over rounds) of the figures
    present in both revisions; keys are :func:`figure_key` strings."""
    rows = []
    for key in [k for k in a if k in b]:
        unit = key.rsplit("[", 1)[-1].rstrip("]")
        ma, mb = stats(a[key])["median"], stats(b[key])["median"]
        rows.append({"figure": key, "unit": unit, "a": ma, "b": mb, "ratio_b_over_a": mb / ma if ma else None})
    return rows


def regressions(rows: list[dict], fail_above: float) -> list[dict]:
    """The rows of :func:`compare_figures` that regress by more than ``fail_above`` (e.g. 1.2 for
    20 %): a time whose ratio B / A exceeds it, or a rate whose ratio falls below its inverse.
    Figures that are neither times nor rates (memory, accuracy) never count."""
    if not fail_above > 1.0:
        raise ValueError(f"fail_above: {fail_above}, expected a ratio above 1 (1.2 = 20 % slower)")
    bad = []
    for r in rows:
        q = r.get("ratio_b_over_a")
        if q is None:
            continue
        if (is_time(r["unit"]) and q > fail_above) or (is_rate(r["unit"]) and q < 1.0 / fail_above):
            bad.append(r)
    return bad
