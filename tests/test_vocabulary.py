"""One vocabulary on the command line (issue 27, item 4): every option that names an unwrapping
method or a worker count is built from the one definition in :mod:`fringe3d.commands.vocabulary`;
method names are shown with hyphens and accepted in both spellings; ``--workers`` (which meant
Dask processes in ``reconstruct`` and threads in ``strain``) is only a deprecated alias."""
from __future__ import annotations

import pytest
from typer.core import TyperOption

from fringe3d.cli import main
from fringe3d.commands import vocabulary
from fringe3d.commands.deprecated import rewrite_deprecated
from fringe3d.commands.lazy import all_commands
from fringe3d.patterns.method_registry import method_names

WORKER_WORDS = {"--workers", "--dask-workers", "--processes", "--threads", "--jobs"}


def options():
    """(command name, click option) for every option of every sub-command (nested groups too)."""
    def walk(name, cmd):
        if getattr(cmd, "commands", None):
            for sub_name, sub in cmd.commands.items():
                yield from walk(f"{name} {sub_name}", sub)
        for p in cmd.params:
            if isinstance(p, TyperOption):
                yield name, p
    for name, cmd in all_commands().items():
        yield from walk(name, cmd)


def test_every_method_option_is_the_shared_definition():
    found = [(c, p) for c, p in options() if "--method" in p.opts]
    assert {c for c, _ in found} >= {"decode", "reconstruct"}
    for command, p in found:
        callback = getattr(p.callback, "__wrapped__", p.callback)  # typer wraps it
        assert (callback.__module__, callback.__qualname__) == (vocabulary.__name__, "canonical_method"), \
            f"{command} --method has its own definition"
        assert all(m in p.help for m in vocabulary.method_choices()), command


def test_every_worker_count_option_is_processes_or_threads_from_the_shared_definition():
    found = [(c, p) for c, p in options() if WORKER_WORDS & set(p.opts)]
    assert found, "reconstruct and strain take worker counts"
    for command, p in found:
        assert p.opts in (["--processes"], ["--threads"]), f"{command} {p.opts}: one word, one meaning"
        if p.opts == ["--processes"]:
            assert "worker processes" in p.help and "thread" not in p.help, command
        else:
            assert "threads" in p.help and "worker process" not in p.help, command
    assert {c for c, p in found if p.opts == ["--processes"]} == {"reconstruct", "strain"}


@pytest.mark.parametrize("spelling", ["gray-code", "gray_code", "GRAY-CODE".lower()])
def test_method_names_are_accepted_with_hyphens_or_underscores(spelling):
    assert vocabulary.canonical_method(spelling) == "gray_code"


def test_every_method_is_shown_with_hyphens_and_round_trips():
    for name in method_names():
        shown = vocabulary.shown(name)
        assert "_" not in shown and vocabulary.canonical_method(shown) == name


def test_an_unknown_method_is_refused_with_a_readable_list(tmp_path, capsys):
    assert main(["reconstruct", str(tmp_path), "-c", str(tmp_path / "rig.json"), "-o", str(tmp_path / "o"),
                 "--method", "grey-code"]) == 2
    err = capsys.readouterr().err
    assert "--method" in err and "gray-code" in err and "'grey-code'" in err
    assert "[" not in err and "gray_code" not in err
    assert not (tmp_path / "o").exists()


def test_workers_is_a_deprecated_alias_of_each_commands_old_meaning(capsys):
    assert rewrite_deprecated("reconstruct", ["--workers", "2"]) == ["--processes", "2"]
    assert rewrite_deprecated("strain", ["--workers=3", "--dask-workers", "2"]) == ["--threads=3", "--processes", "2"]
    assert capsys.readouterr().err.count("deprecated") == 3


SET_WORDS = {"--set", "--patterns", "--layout", "--pattern-set"}


def test_every_pattern_set_option_is_one_set_option():
    found = [(c, p) for c, p in options() if SET_WORDS & set(p.opts)]
    assert {c for c, _ in found} >= {"patterns", "simulate", "import", "decode", "calibrate"}
    for command, p in found:
        assert p.opts == ["--set"] and p.metavar == "<set>", f"{command} {p.opts}: one name for a pattern set"


def test_one_set_name_means_one_set_in_patterns_and_simulate(capsys):
    from fringe3d.patterns import sets
    from fringe3d.sim.simulate import make_patterns
    # `patterns --set calibration` and `simulate --set calibration`: the same 31 frames
    assert len(make_patterns("calibration", 800, 600)) == len(sets.calibration(800, 600)) == 31
    # simulate's old three-frequency (31 frames) is refused the name with a warning, not silently kept
    assert vocabulary.set_word("simulate", "three-frequency") == "calibration"
    assert "deprecated" in capsys.readouterr().err
    assert vocabulary.set_word("patterns", "three-frequency") == "three-frequency"


def test_old_set_option_spellings_are_deprecated_aliases():
    assert rewrite_deprecated("simulate", ["--patterns", "ftp"]) == ["--set", "ftp"]
    assert rewrite_deprecated("calibrate", ["--patterns=gray-code"]) == ["--set=gray-code"]
    for command in ("import", "decode", "calibrate"):
        assert rewrite_deprecated(command, ["--layout", "opencv-graycode"]) == ["--set", "opencv-graycode"]


@pytest.mark.parametrize("command", ["strain", "reconstruct", "decode"])
def test_help_shows_no_bool_value_for_flags_and_keeps_extras_brackets(command, capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "200")
    assert main([command, "--help"]) == 0
    out = capsys.readouterr().out
    assert "--overwrite" in out and "<bool>" not in out
    assert "fringe3d[dask]" in out or command == "decode"


def test_a_repeated_warning_is_shown_once_with_its_count(capsys, monkeypatch):
    import warnings

    from fringe3d import cli
    from fringe3d.utils.warning_types import CalibrationWarning

    def noisy(**_kwargs):
        for _ in range(8):
            warnings.warn_explicit("pose p: board not found", CalibrationWarning, "x.py", 1)
        return 0
    monkeypatch.setattr(cli, "app", noisy)
    assert cli.main(["anything", "-q"]) == 0
    err = capsys.readouterr().err
    assert err.count("pose p: board not found") == 2  # the warning, then its count
    assert "raised 8 times" in err
