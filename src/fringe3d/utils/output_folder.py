"""Output folders that never lose or expose data: one guard for every command that writes.

A command writes through :func:`open_output` (a folder) or :func:`open_output_file` (one file):

- The output is resolved (symlinks followed) and must not be, contain or lie inside one of the
  command's inputs.
- A non-empty folder (an existing file) is refused unless ``overwrite``. With ``overwrite`` a
  folder is written into a fresh temporary sibling and swapped in only when complete, so an
  interrupted overwrite leaves the old set untouched.
- While the block runs, every atomic write (:mod:`fringe3d.utils.atomic`) must land inside the
  output: a path that resolves elsewhere (``../``, an absolute name, a symlinked sub-folder) is
  refused with :class:`OutsideOutputError`.
- A folder carries ``fringe3d.json`` (:data:`MARKER_NAME`): written first with
  ``"complete": false`` and the inputs' fingerprint, rewritten with ``"complete": true``, the
  fringe3d version, the command and the file list as the very last step. Readers call
  :func:`check_complete` and refuse an unfinished set with a message saying how to finish it.
- ``resumable`` outputs (long sequences) may continue an unfinished set made from the same inputs
  and options (same fingerprint); another fingerprint is refused, and an advisory lock
  (``fcntl.flock``) stops a second writer.
"""
from __future__ import annotations

import datetime as _dt
import hashlib
import json
import os
import shlex
import shutil
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Iterator

from fringe3d.utils.atomic import atomic_write_text
from fringe3d.utils.provenance import FOLDER_UNITS, _CommandLine, command_line, version
from fringe3d.utils.write_guard import OutsideOutputError, guard_write, is_being_written, writing_into

__all__ = ["open_output", "set_command_line", "request_interrupt", "interrupt_requested",
           "open_output_file", "check_complete", "read_marker", "fingerprint",
           "clean_partials", "OutsideOutputError", "BusyOutputError", "guard_write", "MARKER_NAME"]

MARKER_NAME = "fringe3d.json"
LOCK_NAME = ".fringe3d.lock"
MARKER_FORMAT = "fringe3d-output"


class _Interrupt:
    #: Set by the CLI's SIGINT handler: a Ctrl-C swallowed somewhere (a C callback) still stops
    #: the output from being marked complete.
    requested = False


def request_interrupt(flag: bool = True) -> None:
    """Note (or clear) that the user asked to stop; :func:`open_output` then never marks complete."""
    _Interrupt.requested = flag


def interrupt_requested() -> bool:
    return _Interrupt.requested


def set_command_line(argv: list[str]) -> None:
    """Record ``fringe3d ARGV...`` as the command that writes outputs from now on."""
    _CommandLine.text = "fringe3d " + " ".join(shlex.quote(a) for a in argv)

class BusyOutputError(OSError):
    """Another fringe3d run holds the output's lock."""


def provenance_comments() -> list[str]:
    """``fringe3d <version>`` and the command line now writing outputs, for file-header comments
    (``command: none (Python API)`` when no command line is recorded: never an empty one)."""
    return [f"fringe3d {version()}", f"command: {command_line() or 'none (Python API)'}"]


# -- fingerprints ---------------------------------------------------------------------------
def fingerprint(inputs: Iterable[str | os.PathLike | None], options: dict | None = None) -> str:
    """SHA-256 over the inputs and options: JSON/text files by content, other files by name, size
    and modification time (frames are many and large), folders recursively; ``options`` by value."""
    h = hashlib.sha256()
    for p in inputs:
        if p is None:
            continue
        path = Path(p)
        files = sorted(q for q in path.rglob("*") if q.is_file()) if path.is_dir() else [path]
        for f in files:
            if f.name in (MARKER_NAME, LOCK_NAME):
                continue
            h.update(str(f.relative_to(path) if path.is_dir() else f.name).encode())
            try:
                st = f.stat()
            except OSError:
                h.update(b"missing")
                continue
            if f.suffix.lower() in (".json", ".txt", ".yml", ".yaml") and st.st_size < 1 << 24:
                h.update(f.read_bytes())
            else:
                h.update(f"{st.st_size}:{st.st_mtime_ns}".encode())
    h.update(json.dumps(options or {}, sort_keys=True, default=str).encode())
    return h.hexdigest()


# -- completion markers -----------------------------------------------------------------------
def read_marker(folder: str | os.PathLike) -> dict | None:
    """The folder's ``fringe3d.json`` as a dict, or None when it has none (a hand-made folder)."""
    path = Path(folder) / MARKER_NAME
    if not path.is_file():
        return None
    try:
        d = json.loads(path.read_text())
    except (OSError, ValueError, RecursionError):
        raise ValueError(f"{path} is damaged (not valid JSON); the set it describes cannot be trusted: "
                         "make it again with --overwrite") from None
    if not isinstance(d, dict) or d.get("format") != MARKER_FORMAT:
        raise ValueError(f"{path}: expected a JSON object with format {MARKER_FORMAT!r}")
    return d


def check_complete(folder: str | os.PathLike, what: str = "output folder") -> None:
    """Refuse a set whose writer did not finish (``fringe3d.json`` says ``complete: false``); the
    output this process is writing (a command reading back its own files) passes."""
    if is_being_written(folder):
        return
    d = read_marker(folder)
    if d is not None and d.get("complete") is not True:
        cmd = d.get("command") or "the command"
        raise ValueError(f"{what} {folder} is incomplete: `{cmd}` did not finish writing it "
                         f"({MARKER_NAME} has complete: false). Run the command again (a sequence resumes) "
                         "or with --overwrite to start over")


def _write_marker(folder: Path, info: dict) -> None:
    atomic_write_text(folder / MARKER_NAME, json.dumps(info, indent=1))


def _file_list(folder: Path) -> list[dict]:
    out = []
    for f in sorted(folder.rglob("*")):
        if f.is_file() and f.name not in (MARKER_NAME, LOCK_NAME):
            out.append({"path": f.relative_to(folder).as_posix(), "bytes": f.stat().st_size})
    return out


# -- the output block -------------------------------------------------------------------------
@dataclass
class Output:
    """What :func:`open_output` yields: ``path`` to write into and whether the run ``resumed``."""

    path: Path
    final: Path
    resumed: bool = False

    def final_paths(self, obj):
        """``obj`` (a summary: dicts, lists, strings) with every path under :attr:`path` rewritten to
        where it will be once the output is in place (they differ while ``--overwrite`` builds aside)."""
        if self.path == self.final:
            return obj
        if isinstance(obj, dict):
            return {k: self.final_paths(v) for k, v in obj.items()}
        if isinstance(obj, (list, tuple)):
            return type(obj)(self.final_paths(v) for v in obj)
        if isinstance(obj, (str, Path)):
            text, tmp = str(obj), str(self.path)
            if text == tmp or text.startswith(tmp + os.sep):
                return type(obj)(str(self.final) + text[len(tmp):])
            abs_tmp = str(self.path.resolve())
            if text.startswith(abs_tmp + os.sep) or text == abs_tmp:
                return type(obj)(str(self.final) + text[len(abs_tmp):])
        return obj


def _refuse_symlink(out: str | os.PathLike) -> None:
    """An output that is itself a symbolic link would write (or, with --overwrite, replace) its target."""
    if Path(out).is_symlink():
        raise ValueError(f"output {out} is a symbolic link (to {os.readlink(Path(out))}); give the real path of a "
                         "folder or file to write")


def _check_not_inputs(out: Path, inputs: Iterable[str | os.PathLike | None]) -> None:
    for p in inputs:
        if p is None:
            continue
        src = Path(p).resolve()
        if out == src or src in out.parents:
            raise ValueError(f"output {out} lies inside the input {p}; choose an output folder outside it")
        if out in src.parents:
            raise ValueError(f"the input {p} lies inside the output {out}; writing there could destroy it, "
                             "choose another output folder")


def _lock(folder: Path):
    fd = os.open(folder / LOCK_NAME, os.O_CREAT | os.O_RDWR, 0o644)
    try:
        import fcntl
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise BusyOutputError(f"another fringe3d run is writing {folder}; wait for it to finish or choose "
                              "another output folder") from None
    except ImportError:  # pragma: no cover - no fcntl (Windows): no advisory lock
        pass
    return fd


def _unlock(fd: int, folder: Path) -> None:
    os.close(fd)
    (folder / LOCK_NAME).unlink(missing_ok=True)


def clean_partials(folder: Path) -> int:
    """Remove temporaries (``.NAME.XXXX.part…``) an interrupted run left in ``folder``; their count."""
    n = 0
    for f in folder.rglob(".*.part*"):
        if f.is_file():
            f.unlink(missing_ok=True)
            n += 1
    return n


@contextmanager
def open_output(out: str | os.PathLike, *, command: str = "", overwrite: bool = False,
                inputs: Iterable[str | os.PathLike | None] = (), options: dict | None = None,
                resumable: bool = False) -> Iterator[Output]:
    """Guarded writing of an output folder (see the module docstring).

    Parameters
    ----------
    out : output folder (created when missing)
    command : the command line, recorded in ``fringe3d.json`` and quoted in messages (default: the
        one the CLI recorded with :func:`set_command_line`)
    overwrite : replace an existing non-empty folder (atomically, by a swap at the end)
    inputs : folders/files the command reads; the output may not be, hold or lie in one of them
    options : the options that shape the result, part of the fingerprint
    resumable : an unfinished set with the same fingerprint is continued instead of refused

    Raises ``ValueError`` (bad request: non-empty folder, output in an input, an unfinished set of
    other inputs), :class:`BusyOutputError` (another run holds the lock).
    """
    inputs_: list[str | os.PathLike] = [p for p in inputs if p is not None]
    _refuse_symlink(out)
    final = Path(out).resolve()
    if final.exists() and not final.is_dir():
        raise ValueError(f"output {out} is a file; expected a folder")
    _check_not_inputs(final, inputs_)
    fp = fingerprint(inputs_, options)
    info = {"format": MARKER_FORMAT, "version": 1, "fringe3d": version(), "command": command or _CommandLine.text,
            "started": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "complete": False, "inputs": [str(Path(p)) for p in inputs_], "fingerprint": fp,
            "units": dict(FOLDER_UNITS)}
    nonempty = final.is_dir() and any(p.name != LOCK_NAME for p in final.iterdir())
    if nonempty and not overwrite:
        marker = read_marker(final)
        if not (resumable and marker is not None and marker.get("complete") is not True):
            raise ValueError(f"output folder {out} is not empty; choose a new folder or pass --overwrite to "
                             "replace its contents")
        if marker.get("fingerprint") != fp:
            raise ValueError(f"output folder {out} holds an unfinished run made from other inputs or options; "
                             "resume with the same inputs and options, or pass --overwrite to start over")
        yield from _resume(final, info, marker)
        return
    if nonempty:
        yield from _replace(final, info)
        return
    yield from _fresh(final, info)


def _finish(folder: Path, info: dict) -> None:
    if _Interrupt.requested:
        raise KeyboardInterrupt
    info = {**info, "complete": True,
            "finished": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "files": _file_list(folder)}
    _write_marker(folder, info)


def _fresh(final: Path, info: dict):
    created = not final.exists()
    final.mkdir(parents=True, exist_ok=True)
    try:
        fd = os.open(final / MARKER_NAME, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
    except FileExistsError:
        raise BusyOutputError(f"another fringe3d run started writing {final}; choose another output folder") from None
    os.write(fd, json.dumps(info, indent=1).encode())
    os.close(fd)
    lock = _lock(final)
    ok = False
    try:
        with writing_into(final):
            yield Output(final, final)
        _finish(final, info)
        ok = True
    finally:
        _unlock(lock, final)
        if not ok and created and not _file_list(final):
            shutil.rmtree(final, ignore_errors=True)  # nothing but our marker: leave no trace


def _resume(final: Path, info: dict, marker: dict):
    lock = _lock(final)
    try:
        clean_partials(final)
        info = {**info, "started": marker.get("started", info["started"]), "resumed": True}
        with writing_into(final):
            yield Output(final, final, resumed=True)
        _finish(final, info)
    finally:
        _unlock(lock, final)


def _replace(final: Path, info: dict):
    had_lock = (final / LOCK_NAME).exists()
    old_lock = _lock(final)  # refuse to replace a set another run is still writing
    swapped = False
    try:
        tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=".fringe3d-new", dir=final.parent))
        try:
            _write_marker(tmp, info)
            with writing_into(tmp):
                yield Output(tmp, final)
            _finish(tmp, info)
            trash = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=".fringe3d-old", dir=final.parent))
            os.replace(final, trash / final.name)
            os.replace(tmp, final)
            swapped = True
            shutil.rmtree(trash, ignore_errors=True)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
    finally:
        os.close(old_lock)
        if not swapped and not had_lock:
            (final / LOCK_NAME).unlink(missing_ok=True)


@contextmanager
def open_output_file(*paths: str | os.PathLike | None, overwrite: bool = False,
                     inputs: Iterable[str | os.PathLike | None] = ()) -> Iterator[Path]:
    """Guarded writing of output files: each is refused when it exists (unless ``overwrite``), is a
    folder, or is one of ``inputs``; writes elsewhere are refused while the block runs. Yields the
    first path, resolved. ``None`` paths (outputs not asked for) are skipped."""
    targets = [Path(p) for p in paths if p is not None]
    inputs = [Path(p).resolve() for p in inputs if p is not None]
    for path in targets:
        _refuse_symlink(path)
    for path in targets:
        target = path.resolve()
        if target.is_dir():
            raise ValueError(f"output {path} is a folder; expected a file name")
        if any(target == p or p in target.parents for p in inputs):
            raise ValueError(f"output {path} is also an input (or inside one); choose another file name")
        if target.exists() and not overwrite:
            raise ValueError(f"output file {path} exists; choose another name or pass --overwrite to replace it")
    with writing_into(*targets) as first:
        yield first
