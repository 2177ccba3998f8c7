"""The benchmark harness's arithmetic: the summary table ``make bench`` prints and the regression
rule of ``make bench-check``, on hand-made figures (no timing: every number here is given)."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


def _load(name: str):
    if str(BENCH) not in sys.path:
        sys.path.insert(0, str(BENCH))  # the benchmark scripts import summary.py from beside them
    spec = importlib.util.spec_from_file_location(f"fringe3d_bench_{name}", BENCH / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


summary = _load("summary")
run_all = _load("run_all")
compare = _load("compare_revisions")

G = "decode, 15 frames"


def decode_group(peer_ms: float | None = 100.0) -> list[dict]:
    f = summary.figure
    return [f(G, "decode()", "ours", "ms", [40.0, 38.0, 45.0]),
            f(G, "fused kernel", "kernel", "ms", [10.0, 11.0, 9.0]),
            f(G, "copy bound", "bound", "ms", [2.0, 2.5, 1.5]),
            f(G, "copy + arctan2", "reference", "ms", [30.0]),
            f(G, "fringes", "peer", "ms", None if peer_ms is None else [peer_ms])]


def by_name(rows: list[dict]) -> dict[str, dict]:
    return {r["name"]: r for r in rows}


def test_figure_holds_min_median_max_of_its_rounds():
    f = summary.figure(G, "x", "ours", "ms", [4.0, 1.0, 3.0, 2.0])
    assert (f["min"], f["median"], f["max"], f["rounds"]) == (1.0, 2.5, 4.0, 4)


def test_ratios_are_median_times_over_the_kernel_and_the_bound_of_the_same_group():
    rows = by_name(summary.table_rows(decode_group()))
    assert rows["decode()"]["x_kernel"] == pytest.approx(40.0 / 10.0)
    assert rows["decode()"]["x_bound"] == pytest.approx(40.0 / 2.0)
    assert rows["copy + arctan2"]["x_bound"] == pytest.approx(15.0)
    assert rows["copy bound"]["x_bound"] == pytest.approx(1.0)


def test_peer_column_is_the_fastest_installed_peer_over_the_figure():
    figs = decode_group() + [summary.figure(G, "slower peer", "peer", "ms", [400.0])]
    rows = by_name(summary.table_rows(figs))
    assert rows["decode()"]["peer"] == "2.5x faster than fringes"  # 100 ms / 40 ms, the faster peer
    assert rows["fused kernel"]["peer"] == "10.0x faster than fringes"


def test_missing_peer_reads_peer_not_installed_and_keeps_the_other_ratios():
    rows = summary.table_rows(decode_group(peer_ms=None))
    text = summary.format_table(rows)
    assert by_name(rows)["decode()"]["peer"] == "peer not installed"
    assert by_name(rows)["decode()"]["x_kernel"] == pytest.approx(4.0)
    assert "fringes" in text and "not installed" in text


def test_rates_count_as_inverse_times_in_the_ratios():
    g = "reconstruct"
    figs = [summary.figure(g, "end to end", "ours", "3D frames/s", [50.0]),
            summary.figure(g, "kernel", "kernel", "3D frames/s", [200.0]),
            summary.figure(g, "bound", "bound", "3D frames/s", [1000.0]),
            summary.figure(g, "peak memory", "ours", "MB", [300.0])]
    rows = by_name(summary.table_rows(figs))
    assert rows["end to end"]["x_kernel"] == pytest.approx(4.0)
    assert rows["end to end"]["x_bound"] == pytest.approx(20.0)
    assert rows["peak memory"]["x_kernel"] is None  # not a speed: never compared


def test_rows_of_a_group_run_bound_reference_kernel_ours_peer_and_groups_keep_their_order():
    other = summary.figure("strain", "per frame", "ours", "s", [0.5])
    rows = summary.table_rows([other] + decode_group())
    assert [r["role"] for r in rows] == ["ours", "bound", "reference", "kernel", "ours", "peer"]
    assert rows[0]["group"] == "strain"


def test_table_heading_names_the_scene_and_its_wrap_error_count():
    text = summary.format_table(summary.table_rows(decode_group()),
                                {G: {"scene": "ramp", "wrap_errors": 0}}, "title")
    lines = text.splitlines()
    assert lines[0] == "title"
    assert f"[{G}]  (scene: ramp; wrap errors: 0)" in lines


def test_alternated_rotates_the_order_of_the_cases_every_round():
    calls: list[str] = []
    cases = {k: (lambda k=k: calls.append(k)) for k in "ABC"}
    seconds = summary.alternated(cases, rounds=3)
    assert calls == list("ABC") + list("ABC") + list("BCA") + list("CAB")  # warm-up, then rotated rounds
    assert {k: len(v) for k, v in seconds.items()} == {"A": 3, "B": 3, "C": 3}


def test_regression_rule_fails_times_above_and_rates_below_the_threshold():
    a = {"t [ms]": [10.0, 10.0], "t2 [ms]": [10.0], "r [3D frames/s]": [100.0], "r2 [3D frames/s]": [100.0],
         "m [MB]": [100.0], "only in A [ms]": [1.0]}
    b = {"t [ms]": [12.1, 12.1], "t2 [ms]": [11.9], "r [3D frames/s]": [80.0], "r2 [3D frames/s]": [85.0],
         "m [MB]": [500.0]}
    rows = summary.compare_figures(a, b)
    assert [r["figure"] for r in rows] == ["t [ms]", "t2 [ms]", "r [3D frames/s]", "r2 [3D frames/s]", "m [MB]"]
    assert by_figure(rows)["t [ms]"]["ratio_b_over_a"] == pytest.approx(1.21)
    bad = [r["figure"] for r in summary.regressions(rows, 1.2)]
    assert bad == ["t [ms]", "r [3D frames/s]"]  # 1.21 > 1.2; 0.8 < 1/1.2; 1.19, 0.85 and MB pass


def by_figure(rows: list[dict]) -> dict[str, dict]:
    return {r["figure"]: r for r in rows}


def test_regression_threshold_must_be_a_ratio_above_one():
    with pytest.raises(ValueError, match="fail_above"):
        summary.regressions([], 0.8)


def test_bench_check_gates_only_fringe3d_figures_not_the_machine_bound():
    rows = [{"figure": "copy bound [ms]", "unit": "ms", "ratio_b_over_a": 2.0, "role": "bound"},
            {"figure": "decode() [ms]", "unit": "ms", "ratio_b_over_a": 1.3, "role": "ours"},
            {"figure": "kernel [ms]", "unit": "ms", "ratio_b_over_a": 1.1, "role": "kernel"}]
    assert [r["figure"] for r in compare.failing(rows, 1.2)] == ["decode() [ms]"]
    assert compare.failing(rows, None) == []


def test_run_all_collects_every_benchmark_into_one_table_and_lists_the_skipped():
    results = {"bench_decode.py": {"figures": decode_group(), "groups": {G: {"wrap_errors": 0}}},
               "bench_strain.py": {"figures": [summary.figure("strain", "per frame", "ours", "s", [0.5, 0.7])]}}
    status = {"bench_decode.py": "ok", "bench_strain.py": "ok", "bench_cuda.py": "skipped: no CUDA device"}
    text = run_all.summary(results, status, "header")
    assert text.count("[decode, 15 frames]") == 1 and text.count("[strain]") == 1
    assert "wrap errors: 0" in text
    assert "bench_cuda.py: skipped: no CUDA device" in text


def test_run_all_reads_the_json_object_a_benchmark_printed_after_other_lines():
    assert run_all.parse_json('compiling...\n{\n "figures": []\n}\n') == {"figures": []}
    assert run_all.parse_json("no json here") is None
