"""Property-based (hypothesis) fuzzing of every JSON reader and of the CLI's options.

Each reader, given any JSON document (random, or a valid one with one field replaced by a random
value, or nested beyond any limit), either accepts it or raises ``ValueError``/``FileNotFoundError``
with a message naming the file — never TypeError, KeyError, AttributeError or RecursionError, which
the CLI would show as a traceback. The CLI, given hostile option values and labels, exits 0 or 2,
and nothing outside its output folder changes. Budget: a fixed number of examples, no deadline.
"""
from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from fringe3d.calibrate.calibration_file import load_calibration
from fringe3d.cli import main
from fringe3d.io.capture import read_meta, write_capture
from fringe3d.optics import Rig
from fringe3d.patterns import render_set, sets
from fringe3d.patterns.manifest import PatternSet
from fringe3d.report.results import load_summary
from fringe3d.sim.presets import get as get_preset
from fringe3d.sim.scene_file import load_scene

FUZZ = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture],
                derandomize=True)

json_leaf = st.one_of(st.none(), st.booleans(), st.integers(-10**12, 10**12),
                      st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12))
json_value = st.recursive(json_leaf, lambda kids: st.one_of(st.lists(kids, max_size=4),
                                                            st.dictionaries(st.text(max_size=8), kids, max_size=4)),
                          max_leaves=12)

ALLOWED = (ValueError, FileNotFoundError)


def _valid_documents(tmp: Path) -> dict:
    """One valid document of each file kind, with the reader that reads it."""
    ps = sets.three_frequency("v", width=64, height=32)
    rig = get_preset("tiny").rig
    return {
        "manifest": (ps.to_dict(), lambda p: PatternSet.load(p)),
        "rig": (rig.to_dict(), lambda p: Rig.load(p)),
        "capture": ({"frame_rate": 100.0, "bit_depth": 8, "camera": [64, 32]},
                    lambda p: read_meta(p.parent)),
        "scene": ({"objects": [{"type": "plane", "point": [0, 0, 300], "normal": [0, 0, -1]}]},
                  lambda p: load_scene(p)),
        "summary": ({"title": "t", "measurements": [{"name": "a", "points": "points_a.npy"}]},
                    lambda p: load_summary(p.parent)),
        "calibration": (None, lambda p: load_calibration(p)),
    }


_NAMES = {"manifest": "manifest.json", "rig": "rig.json", "capture": "capture.json", "scene": "scene.json",
          "summary": "summary.json", "calibration": "calib.json"}


def _read(kind: str, tmp: Path, doc) -> None:
    path = tmp / _NAMES[kind]
    path.write_text(json.dumps(doc, allow_nan=True))
    try:
        _valid_documents(tmp)[kind][1](path)
    except ALLOWED as e:
        assert str(e), f"{kind}: an empty error message"


def _paths(doc, prefix=()):
    """Every (path, value) of a JSON document, so one field can be replaced."""
    yield prefix, doc
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from _paths(v, prefix + (i,))


def _replace(doc, path, value):
    if not path:
        return value
    doc = copy.deepcopy(doc)
    node = doc
    for p in path[:-1]:
        node = node[p]
    node[path[-1]] = value
    return doc


@pytest.mark.parametrize("kind", sorted(_NAMES))
@FUZZ
@given(doc=json_value)
def test_any_json_document_is_accepted_or_refused_with_a_value_error(tmp_path, kind, doc):
    _read(kind, tmp_path, doc)


@pytest.mark.parametrize("kind", ["manifest", "rig", "capture", "scene", "summary"])
@FUZZ
@given(data=st.data())
def test_a_valid_document_with_one_field_replaced_is_accepted_or_refused_cleanly(tmp_path, kind, data):
    doc = _valid_documents(tmp_path)[kind][0]
    paths = [p for p, _ in _paths(doc)]
    where = data.draw(st.sampled_from(paths))
    _read(kind, tmp_path, _replace(doc, where, data.draw(json_value)))


@pytest.mark.parametrize("kind", sorted(_NAMES))
@pytest.mark.parametrize("depth", [40, 100_000])
def test_deeply_nested_json_is_a_clear_error_not_a_recursion_error(tmp_path, kind, depth):
    path = tmp_path / _NAMES[kind]
    path.write_text('{"a": ' + "[" * depth + "]" * depth + "}")
    with pytest.raises(ValueError, match="nested"):
        _valid_documents(tmp_path)[kind][1](path)


def _snapshot(root: Path) -> dict:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


path_like = st.lists(st.sampled_from(["..", ".", "x", "", "tmp", "a b", "~"]), min_size=1, max_size=5).map("/".join)


@FUZZ
@example(label="../../x")
@example(label="../../../x")
@example(label="../../../../escaped")
@given(label=st.one_of(st.text(min_size=1, max_size=12), path_like))
def test_no_direction_label_makes_decode_write_outside_its_output(tmp_path_factory, label):
    root = tmp_path_factory.mktemp("label")
    ps = sets.phase_shift(16, 3, "v", width=48, height=8)
    write_capture(root / "cap", (render_set(ps) * 200 + 20).astype(np.uint8), ps)
    d = json.loads((root / "cap" / "manifest.json").read_text())
    for f in d["frames"]:
        f["direction"] = label
    d["plans"][0]["direction"] = label
    (root / "cap" / "manifest.json").write_text(json.dumps(d))
    before = _snapshot(root)
    code = main(["decode", str(root / "cap"), "-o", str(root / "out" / "o"), "-q"])
    assert code in (0, 2)
    after = {k: v for k, v in _snapshot(root).items() if not k.startswith("out/o/")}
    assert after == before, "a file outside the output folder changed"


@FUZZ
@given(value=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**6, 10**6)))
def test_hostile_numeric_options_exit_0_or_2(tmp_path_factory, value):
    root = tmp_path_factory.mktemp("opt")
    ps = sets.phase_shift(16, 3, "v", width=48, height=8)
    write_capture(root / "cap", (render_set(ps) * 200 + 20).astype(np.uint8), ps)
    code = main(["decode", str(root / "cap"), "-o", str(root / "out"), "-q", "--min-modulation", str(value)])
    assert code in (0, 2)
    if not np.isfinite(value) or value < 0:
        assert code == 2 and not (root / "out").exists()


@pytest.mark.parametrize("kind", ["manifest", "rig", "capture", "scene", "summary"])
def test_the_unmodified_documents_the_fuzzer_starts_from_are_read(tmp_path, kind):
    doc, reader = _valid_documents(tmp_path)[kind]
    path = tmp_path / _NAMES[kind]
    path.write_text(json.dumps(doc))
    reader(path)  # raises if the starting point were invalid (the mutation test would then prove nothing)
