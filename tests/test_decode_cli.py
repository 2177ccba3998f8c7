"""``fringe3d decode`` on a capture folder written by fringe3d.io.capture."""
import json
import math

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.decode import Decoded
from fringe3d.io.capture import write_capture
from fringe3d.patterns import sets

H, W = 64, 96


def capture_frames(ps, shift=0.0):
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    up = 12.0 + 7.9 * u + 0.2 * v + shift
    out = [120 + 90 * np.cos(2 * np.pi * up / f.period + f.shift) for f in ps.frames]
    return np.clip(np.round(out), 0, 255).astype(np.uint8), 2 * np.pi * up / ps.plans[0].periods[0]


def test_decode_command_writes_phase_and_json_summary(tmp_path, capsys):
    ps = sets.three_frequency("v")
    frames, truth = capture_frames(ps)
    write_capture(tmp_path / "cap", frames, ps, {"bit_depth": 8})
    code = main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "out"), "--json"])
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["cycles"] == 1 and summary["results"][0]["directions"]["v"]["valid_fraction"] == 1.0
    d = Decoded.load(tmp_path / "out")
    assert not np.round((d.phase["v"] - truth) / (2 * math.pi)).any()
    assert (tmp_path / "out" / "phase_v.tif").exists()


def test_decode_command_sequence_writes_one_folder_per_cycle(tmp_path, capsys):
    ps = sets.three_frequency("v")
    cycles = [capture_frames(ps, shift=s) for s in (0.0, 3.0)]
    write_capture(tmp_path / "cap", np.concatenate([c[0] for c in cycles]), ps)
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "out"), "--quiet"]) == 0
    for i, (_, truth) in enumerate(cycles):
        d = Decoded.load(tmp_path / "out" / f"cycle_{i:05d}")
        assert not np.round((d.phase["v"] - truth) / (2 * math.pi)).any()


def test_decode_command_bad_capture_exits_2(tmp_path, capsys):
    assert main(["decode", str(tmp_path / "missing"), "-o", str(tmp_path / "out")]) == 2
    assert "does not exist" in " ".join(capsys.readouterr().err.split())


def test_decode_of_a_dark_capture_warns_and_refuses_an_empty_result_unless_allowed(tmp_path, capsys):
    ps = sets.three_frequency("v")
    write_capture(tmp_path / "cap", np.zeros((15, H, W), np.uint8), ps)
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "out"), "--json"]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "dark" in err and "no valid pixel in any direction" in err and "modulation threshold" in err
    assert not (tmp_path / "out").exists()  # nothing written
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "out"), "--json", "--allow-empty"]) == 0
    captured = capsys.readouterr()
    assert "dark" in captured.err
    assert json.loads(captured.out)["results"][0]["directions"]["v"]["valid_fraction"] == 0.0


def test_decode_help_has_example(capsys):
    with pytest.raises(SystemExit):
        from fringe3d.cli import app
        app(["decode", "--help"])
    assert "Example:" in capsys.readouterr().out


def test_error_messages_keep_square_brackets_literally(tmp_path, capsys):
    from fringe3d.cli import main
    missing = tmp_path / "take[raw]"  # rich markup would swallow "[raw]"
    assert main(["decode", str(missing), "-o", str(tmp_path / "out")]) == 2
    assert "take[raw]" in capsys.readouterr().err.replace("\n", "")


@pytest.mark.parametrize("flag", [["--interleave"], ["--white-black", "first"]])
def test_layout_flags_on_a_capture_folder_are_refused_not_ignored(tmp_path, capsys, flag):
    from fringe3d.cli import main
    out = tmp_path / "out"
    assert main(["decode", str(tmp_path), "-o", str(out), *flag]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert flag[0] in err and "manifest already says how its frames are laid out" in err
    assert not out.exists()


def test_decode_capture_is_a_library_call_that_resumes_the_cycles_already_written(tmp_path):
    from fringe3d.decode import decode_capture
    ps = sets.three_frequency("v")
    cycles = [capture_frames(ps, shift=s) for s in (0.0, 3.0)]
    frames = np.concatenate([c[0] for c in cycles])

    class StopsAtCycleOne:  # an interrupted run: the second cycle is never read
        def __getitem__(self, s):
            if s.start >= len(ps):
                raise KeyboardInterrupt
            return frames[s]

    with pytest.raises(KeyboardInterrupt):
        decode_capture(StopsAtCycleOne(), ps, tmp_path / "out", cycles=2)
    again = decode_capture(frames, ps, tmp_path / "out", cycles=2)
    assert [r["cycle"] for r in again] == [0, 1] and [r.get("resumed", False) for r in again] == [True, False]
    for i, (_, truth) in enumerate(cycles):
        d = Decoded.load(tmp_path / "out" / f"cycle_{i:05d}")
        assert not np.round((d.phase["v"] - truth) / (2 * math.pi)).any()
    first = decode_capture(frames, ps, tmp_path / "fresh", cycles=2)
    assert again[0]["directions"] == first[0]["directions"]


def test_decode_capture_takes_its_output_guard_whole_refusing_overwrite_and_an_output_inside_an_input(tmp_path):
    from fringe3d.decode import decode_capture
    from fringe3d.utils.output_folder import OutputGuard
    ps = sets.three_frequency("v")
    frames, truth = capture_frames(ps)
    decode_capture(frames, ps, tmp_path / "out")
    with pytest.raises(ValueError, match="overwrite"):
        decode_capture(frames, ps, tmp_path / "out")
    decode_capture(frames, ps, tmp_path / "out", guard=OutputGuard(overwrite=True, fingerprint={"run": 2}))
    assert not np.round((Decoded.load(tmp_path / "out").phase["v"] - truth) / (2 * math.pi)).any()
    with pytest.raises(ValueError, match="inside"):
        decode_capture(frames, ps, tmp_path / "out" / "sub", guard=OutputGuard(inputs=[tmp_path / "out"]))


def test_an_empty_cycle_names_the_parameter_to_python_and_the_flag_on_the_command_line(tmp_path, capsys):
    from fringe3d.decode import decode_capture
    ps = sets.three_frequency("v")
    with pytest.warns(UserWarning), pytest.raises(ValueError, match=r"pass `allow_empty=True` to write it anyway"):
        decode_capture(np.zeros((15, H, W), np.uint8), ps, tmp_path / "py", name="dark take")
    assert not (tmp_path / "py").exists()
    write_capture(tmp_path / "cap", np.zeros((15, H, W), np.uint8), ps)
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "out")]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "pass --allow-empty to write it anyway" in err and "`" not in err


def test_a_decoded_direction_is_one_typed_record_of_the_same_arrays(tmp_path):
    from fringe3d.decode import DirectionMaps, decode
    ps = sets.three_frequency("v")
    frames, truth = capture_frames(ps)
    dec = decode(frames, ps)
    v = dec["v"]
    assert isinstance(v, DirectionMaps) and list(dec) == ["v"] and list(dec.by_direction()) == ["v"]
    assert v.phase is dec.phase["v"] and v.mask is dec.mask["v"] and v.quality is dec.quality["v"]
    assert v.period == dec.period["v"] and v.method == dec.method["v"]
    assert not np.round((v.phase - truth) / (2 * math.pi)).any()
    assert np.array_equal(v.projector_coordinate(), dec.projector_coordinate("v"), equal_nan=True)
    with pytest.raises(KeyError, match="no fringe direction 'h'"):
        dec["h"]


def test_the_decode_files_live_in_io_and_a_load_save_round_trip_rewrites_them_byte_for_byte(tmp_path):
    from fringe3d.decode import decode
    from fringe3d.io.decoded_files import NPZ_NAME, read_decoded_npz
    ps = sets.three_frequency("v")
    frames, _ = capture_frames(ps)
    frames[:, :5, :5] = 0  # some invalid pixels: NaN in the phase TIFFs
    dec = decode(frames, ps)
    dec.save(tmp_path / "a")
    Decoded.load(tmp_path / "a").save(tmp_path / "b")
    files = sorted(p.name for p in (tmp_path / "a").iterdir())
    assert files == sorted(p.name for p in (tmp_path / "b").iterdir()) and "phase_v.tif" in files
    for name in files:
        if name != "decoded.json":  # holds the time it was written
            assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name
    meta, arrays = read_decoded_npz(tmp_path / "a" / NPZ_NAME)
    assert meta["directions"] == ["v"] and np.array_equal(arrays["phase_v"], dec.phase["v"], equal_nan=True)


def test_decode_capture_lets_the_caller_add_to_each_cycle_folder_and_summary(tmp_path):
    from fringe3d.decode import decode_capture
    ps = sets.three_frequency("v")
    frames = np.concatenate([capture_frames(ps, shift=s)[0] for s in (0.0, 3.0)])

    def mark(folder, summary):
        (folder / "extra.txt").write_text("x")
        summary["extra"] = folder.name

    out = decode_capture(frames, ps, tmp_path / "out", cycles=2, on_cycle=mark)
    assert [r["extra"] for r in out] == ["cycle_00000", "cycle_00001"]
    assert (tmp_path / "out" / "cycle_00001" / "extra.txt").read_text() == "x"
