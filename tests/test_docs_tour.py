"""The README's "A five-minute tour" and the user guide run as written (issue 27, item 5): each
shell block is executed in a fresh folder (the test's ``tmp_path`` as working directory), its
``fringe3d`` lines in-process through :func:`fringe3d.cli.main`, and every line must exit 0 and
leave the files the documents say it writes. ``tests/test_docs_commands.py`` checks that the same
lines parse; this file runs them.

Markers in the markdown, an HTML comment on the line right before a block:

* ``<!-- tour: setup NAME -->``: the block prepares data (shell or Python). It runs once, in a
  folder of its own, and its files are copied into the folder of each block that
  ``<!-- tour: uses NAME[, NAME] -->``.
* ``<!-- tour: skip (REASON) -->``: the block cannot run here (hardware, another tool's data);
  the reason is required.

To keep the file fast, the lines run on the tiny rig (:data:`FAST`: the documented small
profile/preset/variant options added to the documented command lines); nothing else is changed.
"""
from __future__ import annotations

import json
import re
import shlex
import shutil
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from fringe3d.cli import main

ROOT = Path(__file__).resolve().parents[1]
TOUR_HEADING = "## A five-minute tour"
BLOCK = re.compile(r"(?:^<!-- tour: (?P<marker>.*?) -->\n)?^```(?P<lang>\w*)\n(?P<body>.*?)^```", re.S | re.M)
SHELL = {"sh", "bash", "shell", "console"}
#: lines of a block that only set up the reader's shell: the test already runs in that environment
SHELL_SETUP = {"source .venv/bin/activate"}

#: documented options that make a documented command the tiny, seconds-long variant of itself:
#: (pattern of the command line, replacement); each must apply to some line (no stale entry)
FAST = (
    (re.compile(r"^fringe3d demo\b"), "fringe3d demo --profile tiny"),  # 'tiny' (seconds): demo --help
    (re.compile(r"^(fringe3d experiment (?!--list)[\w-]+)"), r"\1 --quick"),  # "used by the tests"
    (re.compile(r"--(preset|simulate) macro\b"), r"--\1 tiny"),  # the 160x128 test rig
)

#: files the documents say a command writes (besides its -o/--yaml/--plot targets): (pattern of
#: the command line as documented, globs relative to the block's folder that must each match; a
#: ``(glob, n)`` pair must match exactly n files)
WRITES = (
    (r"^fringe3d patterns --set three-frequency -o pat\b", [("pat/*.png", 15)]),  # README: "15 PNGs + manifest"
    (r"^fringe3d patterns .*-o (\S+)", [r"\1/manifest.json", r"\1/00000.png"]),
    (r"^fringe3d simulate (?!.*--views).*-o (\S+)", [r"\1/manifest.json", r"\1/capture.json", r"\1/frames/00000.png",
                                                     r"\1/truth/*", r"\1/rig.json"]),
    (r"^fringe3d simulate .*--views.*-o (\S+)", [r"\1/poses.json", r"\1/view-00/manifest.json",
                                                r"\1/view-00/capture.json", r"\1/view-00/truth/*"]),
    (r"^fringe3d decode .*-o (\S+)", [r"\1/decoded.json", r"\1/decoded.npz", r"\1/quality_*.tif"]),
    (r"^fringe3d reconstruct .*-o (\S+)", [r"\1/quality.tif", r"\1/sigma_z.tif", r"\1/depth.tif"]),
    (r"^fringe3d reconstruct .*-o (\S+) --ply", [r"\1/*.ply"]),
    (r"^fringe3d evaluate (\S+) --truth", [r"\1/evaluate.json", r"\1/truth_error.tif"]),
    (r"^fringe3d evaluate (\S+) --sphere", [r"\1/evaluate.json", r"\1/sphere_residuals.tif"]),
    (r"^fringe3d report (\S+?)/?(?: |$)(?!.*-o)", [r"\1/report.html"]),
    (r"^fringe3d calibrate (?!--import)(?!.*--no-plot).*-o (\S+)\.json", [r"\1.png"]),  # "writes a residual plot"
    (r"^fringe3d import .*-o (\S+)", [r"\1/manifest.json", r"\1/capture.json"]),
    (r"^fringe3d demo .*-o (\S+)", [r"\1/report.html", r"\1/summary.json", r"\1/*.ply"]),
)


@dataclass
class Block:
    doc: str
    section: str
    lang: str
    body: str
    marker: str | None
    index: int
    uses: list[str] = field(default_factory=list)

    @property
    def id(self) -> str:
        return f"{self.doc}:{self.section[:40]}:{self.index}"


def tour_text() -> str:
    """The README's tour section: from its heading to the next ``## `` heading."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    start = text.index(TOUR_HEADING)
    end = text.find("\n## ", start + len(TOUR_HEADING))
    return text[start:end if end >= 0 else None]


def blocks(doc: str, text: str) -> list[Block]:
    """The fenced blocks of ``text`` with their marker and the ``##``/``###`` section holding them."""
    found = []
    for m in BLOCK.finditer(text):
        headings = re.findall(r"^#{2,4} (.+)$", text[:m.start()], re.M)
        found.append(Block(doc, headings[-1] if headings else "", m["lang"], m["body"], m["marker"], len(found)))
    return found


def all_blocks() -> list[Block]:
    return blocks("README.md", tour_text()) + blocks("docs/user-guide.md",
                                                     (ROOT / "docs/user-guide.md").read_text(encoding="utf-8"))


MARKER = re.compile(r"^(?:setup (?P<setup>[\w-]+)|uses (?P<uses>[\w-]+(?:, *[\w-]+)*)|skip \((?P<reason>.+)\))$")


def marker(block: Block, part: str) -> str | None:
    """The ``setup``/``uses``/``reason`` part of the block's marker, if it has that marker."""
    m = MARKER.match(block.marker or "")
    return m[part] if m else None


BLOCKS = all_blocks()
SETUPS = {marker(b, "setup"): b for b in BLOCKS if marker(b, "setup")}
RUN = [b for b in BLOCKS if b.lang in SHELL and not (b.marker and b.marker.startswith(("setup ", "skip ")))]
for _b in RUN:
    _b.uses = [n.strip() for n in (marker(_b, "uses") or "").split(",") if n.strip()]


def command_lines(block: Block) -> list[str]:
    """The lines of a shell block, continuation lines joined, comments and blanks dropped."""
    lines = []
    for line in block.body.replace("\\\n", " ").splitlines():
        line = re.sub(r"\s+", " ", line).strip()
        if line and not line.startswith("#") and line not in SHELL_SETUP:
            lines.append(line)
    return lines


def fast(line: str) -> str:
    for pattern, replacement in FAST:
        line = pattern.sub(replacement, line)
    return line


def run_line(line: str, folder: Path, capsys) -> None:
    """Run one documented line in ``folder``: ``fringe3d ...`` in-process, anything else in a shell."""
    if line.startswith("fringe3d "):
        rc = main(shlex.split(fast(line), comments=True)[1:])
        out = capsys.readouterr()
        assert rc == 0, f"`{line}` (run as `{fast(line)}`) exited {rc}:\n{out.err[-3000:]}"
        check_writes(line, folder)
    else:
        done = subprocess.run(line, shell=True, cwd=folder, capture_output=True, text=True, timeout=60)
        assert done.returncode == 0, f"`{line}` exited {done.returncode}: {done.stderr[-2000:]}"


def check_writes(line: str, folder: Path) -> None:
    """The -o/--yaml/--plot targets of ``line`` exist (an output folder marked complete), and so
    do the files :data:`WRITES` says such a line writes."""
    args = shlex.split(line, comments=True)
    for flag in ("-o", "--output", "--yaml", "--plot"):
        if flag in args:
            target = folder / args[args.index(flag) + 1]
            assert target.exists(), f"`{line}` did not write {args[args.index(flag) + 1]}"
            if target.is_dir():
                marker = json.loads((target / "fringe3d.json").read_text())
                assert marker["complete"] is True, f"`{line}`: {target.name}/fringe3d.json is not complete"
    for pattern, globs in WRITES:
        m = re.search(pattern, line)
        if m:
            for g in globs:
                g, n = (m.expand(g[0]), g[1]) if isinstance(g, tuple) else (m.expand(g), None)
                found = len(list(folder.glob(g)))
                assert found if n is None else found == n, f"`{line}` wrote {found} file(s) {g}, expected {n or 'some'}"


def run_setup(block: Block, folder: Path, capsys) -> None:
    """Run a setup block in ``folder`` (the working directory already)."""
    if block.lang == "python":
        exec(compile(block.body, f"{block.doc} <!-- tour: {block.marker} -->", "exec"), {"__name__": "__tour__"})
    else:
        for line in command_lines(block):
            run_line(line, folder, capsys)


@pytest.fixture(scope="module")
def prepared(tmp_path_factory):
    """NAME -> the folder its setup block ran in; each setup runs once, when first used."""
    done: dict[str, Path] = {}

    def get(name: str, capsys, monkeypatch) -> Path:
        if name not in done:
            folder = tmp_path_factory.mktemp(f"setup-{name}")
            monkeypatch.chdir(folder)
            run_setup(SETUPS[name], folder, capsys)
            done[name] = folder
        return done[name]
    return get


def test_every_marker_is_known_and_every_skip_names_its_reason():
    for b in BLOCKS:
        if b.marker is not None:
            m = MARKER.match(b.marker)
            assert m, f"{b.id}: unknown marker <!-- tour: {b.marker} -->; expected setup NAME, uses NAMES or skip (WHY)"
            assert not m["reason"] or len(m["reason"].split()) >= 3, f"{b.id}: a skip must say why: {b.marker!r}"
    texts = tour_text() + (ROOT / "docs/user-guide.md").read_text(encoding="utf-8")
    assert texts.count("<!-- tour:") == sum(b.marker is not None for b in BLOCKS), \
        "a <!-- tour: ... --> marker is not on the line right before a fenced block"
    skips = [b for b in BLOCKS if b.marker and b.marker.startswith("skip ")]
    assert len(skips) <= 2, f"skips are few: {[b.id for b in skips]}"


def test_every_setup_is_used_and_every_use_is_defined():
    used = {n for b in RUN for n in b.uses}
    assert used == set(SETUPS), f"setups used {sorted(used)} but defined {sorted(SETUPS)}"
    for b in BLOCKS:
        assert b.lang in SHELL | {"python", ""}, f"{b.id}: block language {b.lang!r}"


def test_the_tour_and_the_guide_have_blocks_to_run_and_every_fast_substitution_applies():
    assert {b.doc for b in RUN} == {"README.md", "docs/user-guide.md"}
    lines = [line for b in RUN + list(SETUPS.values()) if b.lang in SHELL for line in command_lines(b)]
    for pattern, _ in FAST:
        assert any(pattern.search(line) for line in lines), f"FAST entry {pattern.pattern!r} matches no line"
    for pattern, _ in WRITES:
        assert any(re.search(pattern, line) for line in lines), f"WRITES entry {pattern!r} matches no line"


@pytest.mark.parametrize("block", RUN, ids=[b.id for b in RUN])
def test_documented_block_runs_as_written_in_a_fresh_folder(block, tmp_path, prepared, capsys, monkeypatch):
    for name in block.uses:
        shutil.copytree(prepared(name, capsys, monkeypatch), tmp_path, dirs_exist_ok=True, symlinks=True)
    monkeypatch.chdir(tmp_path)
    for line in command_lines(block):
        run_line(line, tmp_path, capsys)
