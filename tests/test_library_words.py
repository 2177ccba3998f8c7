"""The library speaks in parameter words; only the command line speaks in flags.

Library messages name parameters in backticks (``\\`shift_sign\\```); ``commands/flag_words``
maps them to flags (``--shift-sign``) where a message reaches a command-line user.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest
import typer

import fringe3d
from fringe3d.cli import app, main
from fringe3d.commands.flag_words import FLAGS, in_flag_words
from fringe3d.io.importer import phase_shift_layout
from fringe3d.patterns import sets
from fringe3d.utils.output_folder import open_output_file

PACKAGE = Path(fringe3d.__file__).parent
FLAG = re.compile(r"--[A-Za-z]")

#: (module, text of the literal) that may name a flag, with the reason
ALLOWED = {
    ("cluster/engine.py", "--resources"): "Dask's own command line (`dask worker --resources GPU=1`), not fringe3d's",
    ("devices/session.py", "fringe3d capture --session"): "provenance written into session.json: the command that "
                                                          "captured it, not a message",
}


def _docstrings(tree: ast.AST) -> set[int]:
    """ids of the docstring constants: they may document the command line."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                out.add(id(first.value))
    return out


def _library_literals(docstrings: bool = False) -> list[tuple[str, int, str]]:
    """(module, line, text) of every string literal (f-string parts included; docstrings only when
    ``docstrings``) of the library modules outside ``commands/`` and ``cli.py``."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        if rel.startswith("commands/") or rel == "cli.py":
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        docs = set() if docstrings else _docstrings(tree)
        found += [(rel, node.lineno, node.value) for node in ast.walk(tree)
                  if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docs]
    return found


#: a docstring may show a command line, whole: a ``fringe3d COMMAND ... --flag`` literal
COMMAND_LINE = re.compile(r"``fringe3d [^`]*``")


def test_no_library_string_outside_the_commands_names_a_flag():
    """Docstrings included: they name parameters too, and show a flag only inside a whole
    ``fringe3d COMMAND --flag`` command line."""
    flags = [f"{rel}:{line}: {text!r}" for rel, line, text in _library_literals(docstrings=True)
             if FLAG.search(COMMAND_LINE.sub("", text)) and not any(rel == m and part in text for m, part in ALLOWED)]
    assert flags == []


def test_every_backticked_word_of_a_library_string_has_its_flag_in_the_table():
    words = {(rel, w) for rel, _, text in _library_literals() for w in re.findall(r"`([^`\s]+)`", text)}
    assert words and {(rel, w) for rel, w in words if w not in FLAGS} == set()


def test_every_flag_of_the_table_is_an_option_of_the_command_line():
    options: set[str] = set()

    def walk(cmd) -> None:
        for p in cmd.params:
            options.update(o for o in (*p.opts, *p.secondary_opts) if o.startswith("--"))
        if hasattr(cmd, "list_commands"):
            for name in cmd.list_commands(None):
                walk(cmd.get_command(None, name))

    walk(typer.main.get_command(app))
    named = {f for text in FLAGS.values() for f in re.findall(r"--[a-z][a-z-]*", text)}
    assert named and named <= options, sorted(named - options)


def test_backticked_table_words_become_flags_and_nothing_else_changes():
    assert in_flag_words("pass `z_min`, or `overwrite=True`; `store_quality=False`") == \
        "pass --z-min, or --overwrite; --no-store-quality"
    assert in_flag_words("z_min and 'z_min' and `z_min_mm` and `dask worker`") == \
        "z_min and 'z_min' and `z_min_mm` and `dask worker`"


def test_a_python_caller_is_told_the_parameter_and_the_command_line_user_the_flag(tmp_path, capsys):
    with pytest.raises(ValueError, match=r"^`shift_sign` must be \+1 or -1, got 2$"):
        phase_shift_layout(sets.phase_shift(16.0, 3, "v", width=64, height=48), None, 2)
    (tmp_path / "src").mkdir()
    rc = main(["import", str(tmp_path / "src"), "-o", str(tmp_path / "out"), "--set", "phase-shift",
               "--projector-size", "64x48", "--period", "16", "--shift-sign", "2"])
    err = " ".join(capsys.readouterr().err.split())
    assert rc == 2 and "--shift-sign must be +1 or -1, got 2" in err and "`" not in err


def test_overwrite_is_a_parameter_to_python_and_a_flag_on_the_command_line(tmp_path, capsys):
    target = tmp_path / "calib.json"
    target.write_text("{}")
    with pytest.raises(ValueError, match=r"pass `overwrite=True` to replace it"):
        with open_output_file(target):
            pass
    (tmp_path / "q").mkdir()
    (tmp_path / "q" / "keep.txt").write_text("x")
    capsys.readouterr()
    rc = main(["patterns", "--set", "phase-shift", "--width", "64", "--height", "48", "-o", str(tmp_path / "q")])
    err = " ".join(capsys.readouterr().err.split())
    assert rc == 2 and "pass --overwrite to" in err and "overwrite=True" not in err
