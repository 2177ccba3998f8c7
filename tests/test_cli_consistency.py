"""One spelling per concept across the sub-commands of ``fringe3d``, and the deprecated aliases."""
import json

import numpy as np
import pytest
import typer

from fringe3d.cli import app, main
from fringe3d.commands.lazy import COMMANDS, all_commands
from fringe3d.commands.deprecated import DEPRECATED, rewrite_deprecated
from fringe3d.io.capture import write_capture
from fringe3d.patterns import sets

#: Commands that take a calibration or rig file.
TAKES_CALIBRATION = {"decode", "reconstruct"}
#: Commands without an output of their own (evaluate writes into the results folder it reads).
NO_OUTPUT = {"evaluate", "warmup"}  # warmup writes only a temporary folder


def _commands() -> dict:
    """The sub-commands as (typer's) click commands."""
    return all_commands()


def _options(cmd) -> dict:
    """Each option spelling of ``cmd`` -> its click option."""
    return {o: p for p in cmd.params if p.param_type_name == "option" for o in (*p.opts, *p.secondary_opts)}


@pytest.mark.parametrize("name", sorted(_commands()))
def test_every_command_spells_its_options_the_same(name):
    cmd = _commands()[name]
    opts = _options(cmd)
    if name not in NO_OUTPUT:
        assert "--output" in opts and "-o" in opts and opts["--output"] is opts["-o"], name
    assert "--out" not in opts, f"{name}: document --output, not --out"
    assert "--rig" not in opts, f"{name}: document --calibration, not --rig"
    if name in TAKES_CALIBRATION:
        assert "--calibration" in opts and "-c" in opts, name
    assert "--quiet" in opts and "-q" in opts and opts["--quiet"].help, name
    assert "--json" in opts, name
    for old in DEPRECATED.get(name, {}):
        assert old not in opts, f"{name}: {old} is deprecated but still documented"


def test_min_modulation_names_and_units():
    cmds = _commands()
    for name in ("decode", "reconstruct"):
        assert "camera counts" in _options(cmds[name])["--min-modulation"].help
    share = _options(cmds["calibrate"])
    assert "--min-modulation" not in share
    assert "95th-percentile" in share["--min-modulation-share"].help and "0-1" in share["--min-modulation-share"].help


def test_help_summaries_are_the_first_words_of_each_commands_own_help():
    commands = _commands()
    assert list(commands) == [entry.name for entry in COMMANDS]
    for entry in COMMANDS:
        own = " ".join((commands[entry.name].help or "").split())
        assert own.startswith(entry.summary), entry.name


def test_help_and_version_import_no_command_module():
    import subprocess
    import sys
    code = ("import sys; from fringe3d.cli import main; rc = main(['--help']); rc2 = main(['--version']); "
            "print(sorted(m for m in sys.modules if m.startswith('fringe3d.commands.')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    light = "['fringe3d.commands.flag_words', 'fringe3d.commands.lazy']"  # the error words' table and the loader
    assert "Commands" in out and out.strip().endswith(light)
    for heavy in ("cv2", "scipy", "numba", "numpy", "importlib.metadata"):
        probe = subprocess.run([sys.executable, "-c", "import sys; from fringe3d.cli import main; main(['--help']); "
                                f"print({heavy!r} in sys.modules)"], capture_output=True, text=True, check=True)
        assert probe.stdout.strip().endswith("False"), heavy



#: Heavy modules each main-work command must not import with its module (issue 29): the temporal decode
#: path needs no scipy.ndimage / skimage (0.25 s, numpy.f2py with them), no calibration fit and no open3d.
NOT_IMPORTED = {"decode": ("scipy.ndimage", "skimage.filters", "numpy.f2py", "scipy.optimize", "open3d"),
                "reconstruct": ("scipy.ndimage", "skimage.filters", "numpy.f2py", "scipy.optimize", "open3d"),
                "live": ("scipy.ndimage", "skimage.filters", "open3d")}


@pytest.mark.parametrize("command", sorted(NOT_IMPORTED))
def test_main_work_commands_leave_heavy_modules_to_the_code_that_uses_them(command):
    import subprocess
    import sys
    code = (f"import sys, fringe3d.commands.{command}; "
            f"print([m for m in {NOT_IMPORTED[command]!r} if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip().splitlines()[-1] == "[]", out

def test_completion_options_exist():
    opts = _options(typer.main.get_command(app))
    assert "--install-completion" in opts and "--show-completion" in opts


def test_rewrite_deprecated_keeps_values_and_warns_once(capsys):
    args = ["cap", "--out", "x", "--rig=r.json", "--out", "y", "--", "--out"]
    assert rewrite_deprecated("decode", args) == ["cap", "--output", "x", "--calibration=r.json", "--output", "y",
                                                  "--", "--out"]
    err = capsys.readouterr().err
    assert err.count("--out is deprecated") == 1 and err.count("--rig is deprecated") == 1
    assert rewrite_deprecated("patterns", ["--out", "x"]) == ["--out", "x"]


def test_old_output_and_rig_spellings_still_work_and_warn(tmp_path, capsys):
    ps = sets.three_frequency("v")
    v, u = np.mgrid[0:48, 0:64].astype(np.float64)
    up = 12.0 + 7.9 * u + 0.2 * v
    frames = np.clip(np.round([120 + 90 * np.cos(2 * np.pi * up / f.period + f.shift) for f in ps.frames]), 0, 255)
    write_capture(tmp_path / "cap", frames.astype(np.uint8), ps, {"bit_depth": 8})
    assert main(["decode", str(tmp_path / "cap"), "--out", str(tmp_path / "dec"), "--json"]) == 0
    out, err = capsys.readouterr()
    assert json.loads(out)["cycles"] == 1  # --json: stdout is JSON only
    assert "warning: --out is deprecated" in err and "--output" in err
    assert (tmp_path / "dec" / "decoded.json").exists()
    # --rig reaches the calibration option: a missing file is reported as the input it is
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "dec2"), "--rig", str(tmp_path / "no.json"),
                 "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--rig is deprecated" in err and "no.json" in err


def test_old_min_modulation_spelling_of_calibrate_is_an_alias(tmp_path, capsys):
    assert main(["calibrate", str(tmp_path), "--min-modulation", "2", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--min-modulation is deprecated" in err and "--min-modulation-share must be at most 1" in err


def test_experiment_list_json_prints_json_only(capsys):
    assert main(["experiment", "--list", "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert listed["experiments"] and {"name", "summary"} <= set(listed["experiments"][0])
