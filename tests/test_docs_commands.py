"""Every ``fringe3d`` command line in the README tour and the user guide is valid as written
(issue 27, item 5, first half): the sub-command exists, every option exists on it in its current
spelling (no deprecated alias), and every value the parser checks (methods, choices, types) is
accepted. The lines are parsed by the commands' own click parsers, not run."""
from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from fringe3d.commands.lazy import COMMANDS, load_command

ROOT = Path(__file__).resolve().parents[1]
DOCS = ("README.md", "docs/user-guide.md")
SHELL_BLOCK = re.compile(r"^```(?:bash|sh|shell|console)\n(.*?)^```", re.S | re.M)


def command_lines(doc: str) -> list[str]:
    """The ``fringe3d ...`` lines of ``doc``'s shell blocks, continuation lines joined."""
    lines = []
    for block in SHELL_BLOCK.findall((ROOT / doc).read_text(encoding="utf-8")):
        for line in block.replace("\\\n", " ").splitlines():
            if line.strip().startswith("fringe3d "):
                lines.append(line.strip())
    return lines


LINES = [(doc, line) for doc in DOCS for line in command_lines(doc)]


def test_the_tour_and_the_guide_have_command_lines():
    assert {doc for doc, _ in LINES} == set(DOCS)
    assert len(LINES) >= 20


@pytest.mark.parametrize("doc, line", LINES, ids=[f"{d}:{line[9:50]}" for d, line in LINES])
def test_every_documented_command_line_parses_in_its_current_spelling(doc, line, capsys):
    args = shlex.split(line, comments=True)[1:]
    if args[0] in ("--help", "--version"):
        return
    assert args[0] in {entry.name for entry in COMMANDS}, f"{doc}: unknown command in {line!r}"
    command = load_command(args[0])
    command.make_context(args[0], args[1:])  # raises (click usage error or ValueError) on a bad line
    err = capsys.readouterr().err
    assert "deprecated" not in err, f"{doc}: {line!r} uses a deprecated spelling: {err}"
