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
- ``resumable`` outputs (long sequences, simulate) may continue an unfinished set made from the
  same inputs and options (same fingerprint); another fingerprint is refused.
- An advisory lock (``fcntl.flock`` on ``.fringe3d.lock``, whose text names the writer's pid,
  host, command and start) is taken before the folder is judged: a second writer is told
  "another fringe3d (pid N, started T) is writing OUT" and never offered ``overwrite=True``. A free
  lock beside an unfinished marker is a dead run's: its ``.part`` files are removed with a
  warning and the set is resumed (resumable) or started over.
- A run that fails or is interrupted keeps a resumable set (marked incomplete) or removes what it
  wrote; :func:`output_note` says which, for the command's message.
"""
from __future__ import annotations

import datetime as _dt
import hashlib
import json
import os
import shlex
import shutil
import socket
import tempfile
import warnings
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Iterator, Mapping, Sequence

from fringe3d.utils.atomic import atomic_write_text
from fringe3d.utils.provenance import FOLDER_UNITS, _CommandLine, command_line, version
from fringe3d.utils.warning_types import OutputWarning
from fringe3d.utils.write_guard import OutsideOutputError, guard_write, is_being_written, writing_into

__all__ = ["open_output", "set_command_line", "request_interrupt", "interrupt_requested",
           "open_output_file", "check_complete", "read_marker", "fingerprint",
           "clean_partials", "OutsideOutputError", "BusyOutputError", "guard_write", "MARKER_NAME", "output_note",
           "OutputGuard"]

MARKER_NAME = "fringe3d.json"
LOCK_NAME = ".fringe3d.lock"
MARKER_FORMAT = "fringe3d-output"


@dataclass(frozen=True)
class OutputGuard:
    """How a library function that writes an output folder guards it (:func:`open_output`): the
    options a caller passes whole instead of one keyword each.

    Attributes
    ----------
    overwrite : bool
        Replace an existing, different output (default False: such an output is refused).
    inputs : sequence of paths
        Input files and folders the run reads (None entries are skipped): the output may not be,
        hold or lie in one of them, and they are fingerprinted into the output (a resumed run must
        have the same inputs). Default none.
    fingerprint : mapping, optional
        The options that shape the result, fingerprinted into the output (a resumed run must have
        the same options); default none.

    Examples
    --------
    >>> OutputGuard(overwrite=True).inputs
    ()
    """

    overwrite: bool = False
    inputs: Sequence[Any] = ()
    fingerprint: Mapping[str, Any] | None = None


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
                         "make it again with `overwrite=True`") from None
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
                         "or with `overwrite=True` to start over")


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
        where it will be once the output is in place (they differ while ``overwrite=True`` builds aside)."""
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
    """An output that is itself a symbolic link would write (or, with ``overwrite=True``, replace) its target."""
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


class _Outcome:
    #: What the last output block left behind when it did not finish, for the CLI's message.
    note = ""


def output_note(clear: bool = False) -> str:
    """What happened to the output of the last block that did not finish (removed, kept for
    resuming, old set kept), as a sentence for the command's error message; "" when none.
    ``clear`` forgets it (a new command starts)."""
    note = _Outcome.note
    if clear:
        _Outcome.note = ""
    return note


def _holder(folder: Path) -> str:
    """``pid N, started T`` of the lock's holder as its lock file records it (or "pid unknown")."""
    try:
        d = json.loads((folder / LOCK_NAME).read_text() or "{}")
    except (OSError, ValueError):
        d = {}
    pid = d.get("pid", "unknown") if isinstance(d, dict) else "unknown"
    started = d.get("started", "at an unknown time") if isinstance(d, dict) else "at an unknown time"
    host = d.get("host") if isinstance(d, dict) else None
    return f"pid {pid}" + (f" on {host}" if host and host != socket.gethostname() else "") + f", started {started}"


def _lock(folder: Path, command: str = ""):
    """Take the output's advisory lock (``fcntl.flock``) and record who holds it (pid, start, host,
    command) in the lock file; :class:`BusyOutputError` naming the holder when a live process has it."""
    fd = os.open(folder / LOCK_NAME, os.O_CREAT | os.O_RDWR, 0o644)
    try:
        import fcntl
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise BusyOutputError(f"another fringe3d ({_holder(folder)}) is writing {folder}; wait for it to finish "
                              "or choose another output folder") from None
    except ImportError:  # pragma: no cover - no fcntl (Windows): no advisory lock
        pass
    me = {"pid": os.getpid(), "host": socket.gethostname(), "command": command or _CommandLine.text,
          "started": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")}
    os.ftruncate(fd, 0)
    os.write(fd, json.dumps(me).encode())
    return fd


def _unlock(fd: int, folder: Path) -> None:
    (folder / LOCK_NAME).unlink(missing_ok=True)
    os.close(fd)


def clean_partials(folder: Path) -> int:
    """Remove temporaries (``.NAME.XXXX.part…``) an interrupted run left in ``folder``; their count."""
    n = 0
    for f in folder.rglob(".*.part*"):
        if f.is_file():
            f.unlink(missing_ok=True)
            n += 1
    return n


def _dead_run(marker: dict) -> str:
    """``the unfinished run of `CMD` (pid N, started T, no longer running)`` for messages."""
    return (f"the unfinished run of `{marker.get('command') or 'fringe3d'}` (pid {marker.get('pid', 'unknown')}, "
            f"started {marker.get('started', 'at an unknown time')}, no longer running)")


@contextmanager
def open_output(out: str | os.PathLike, *, command: str = "", overwrite: bool = False,
                inputs: Iterable[str | os.PathLike | None] = (), options: dict | None = None,
                resumable: bool = False, keep_unfinished: bool = False) -> Iterator[Output]:
    """Guarded writing of an output folder (see the module docstring).

    Parameters
    ----------
    out : output folder (created when missing)
    command : the command line, recorded in ``fringe3d.json`` and quoted in messages (default: the
        one the CLI recorded with :func:`set_command_line`)
    overwrite : replace an existing non-empty folder (atomically, by a swap at the end)
    inputs : folders/files the command reads; the output may not be, hold or lie in one of them
    options : the options that shape the result, part of the fingerprint
    resumable : an unfinished set with the same fingerprint is continued instead of refused; an
        interrupted or failed run keeps its files for that (else a folder the block created is removed)
    keep_unfinished : a failed run keeps what it wrote, marked incomplete, for inspection (a capture's
        frames are data that cannot be made again); a rerun starts over

    The lock is taken before the folder's state is judged, so a live writer is always reported as
    such (:class:`BusyOutputError` naming its pid and start), never as a folder to overwrite. An
    unfinished set whose writer died (its lock is free) is resumed (same fingerprint, resumable),
    or, when it was not resumable, started over with a warning; its ``.part`` temporaries are removed.

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
            "units": dict(FOLDER_UNITS), "pid": os.getpid(), "resumable": resumable}
    _Outcome.note = ""
    created = not final.exists()
    final.mkdir(parents=True, exist_ok=True)
    lock = _lock(final, str(info["command"]))
    try:
        nonempty = any(p.name != LOCK_NAME for p in final.iterdir())
        if nonempty and not overwrite:
            marker = read_marker(final)
            if marker is None or marker.get("complete") is True:
                raise ValueError(f"output folder {out} is not empty; choose a new folder or pass `overwrite=True` to "
                                 "replace its contents")
            if resumable and marker.get("fingerprint") != fp:
                raise ValueError(f"output folder {out} holds {_dead_run(marker)} made from other inputs or options; "
                                 "resume it with the same inputs and options, or pass `overwrite=True` to discard it "
                                 "and start over")
            if resumable:
                yield from _resume(final, info, marker)
                return
            if marker.get("resumable"):
                raise ValueError(f"output folder {out} is not empty: it holds {_dead_run(marker)}, which running "
                                 "that command again resumes; or pass `overwrite=True` to discard it")
            warnings.warn(f"{out} holds {_dead_run(marker)}; starting over (its files are replaced once this run "
                          "completes)", OutputWarning, stacklevel=3)
            nonempty = True
        if nonempty:
            yield from _replace(final, info)
        else:
            yield from _fresh(final, info, created, resumable or keep_unfinished)
    finally:
        _unlock(lock, final)


def _finish(folder: Path, info: dict) -> None:
    if _Interrupt.requested:
        raise KeyboardInterrupt
    info = {**info, "complete": True,
            "finished": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "files": _file_list(folder)}
    _write_marker(folder, info)


def _fresh(final: Path, info: dict, created: bool, resumable: bool):
    _write_marker(final, info)
    ok = False
    try:
        with writing_into(final):
            yield Output(final, final)
        _finish(final, info)
        ok = True
    finally:
        if not ok:
            _failed_fresh(final, created, resumable)


def _failed_fresh(final: Path, created: bool, resumable: bool) -> None:
    """Leave a failed fresh output resumable (marked incomplete) or remove what this run wrote."""
    if resumable and _file_list(final):
        clean_partials(final)
        _Outcome.note = (f"{final} is kept, marked incomplete: run the same command again to "
                         + ("resume it, or pass `overwrite=True` to start over" if _resumes(final) else "start over"))
        return
    if created:
        shutil.rmtree(final, ignore_errors=True)
        _Outcome.note = f"{final} was removed (this run had created it)"
        return
    for p in final.iterdir():  # the folder was empty before this run: empty it again
        if p.name != LOCK_NAME:
            shutil.rmtree(p, ignore_errors=True) if p.is_dir() and not p.is_symlink() else p.unlink(missing_ok=True)
    _Outcome.note = f"what this run wrote in {final} was removed (the folder was empty before)"


def _resumes(folder: Path) -> bool:
    marker = read_marker(folder)
    return bool(marker and marker.get("resumable"))


def _resume(final: Path, info: dict, marker: dict):
    n = clean_partials(final)
    if n:
        warnings.warn(f"removed {n} temporary .part file(s) left in {final} by {_dead_run(marker)}", OutputWarning,
                      stacklevel=4)
    info = {**info, "started": marker.get("started", info["started"]), "resumed": True}
    ok = False
    try:
        with writing_into(final):
            yield Output(final, final, resumed=True)
        _finish(final, info)
        ok = True
    finally:
        if not ok:
            clean_partials(final)
            _Outcome.note = (f"{final} is kept, marked incomplete: run the same command again to resume it, or "
                             "pass `overwrite=True` to start over")


def _replace(final: Path, info: dict):
    tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=".fringe3d-new", dir=final.parent))
    try:
        _write_marker(tmp, info)
        with writing_into(tmp):
            yield Output(tmp, final)
        _finish(tmp, info)
        trash = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=".fringe3d-old", dir=final.parent))
        os.replace(final, trash / final.name)
        os.replace(tmp, final)
        shutil.rmtree(trash, ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        _Outcome.note = f"the new set was discarded; {final} still holds what it held before"
        raise


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
            raise ValueError(f"output file {path} exists; choose another name or pass `overwrite=True` to replace it")
    with writing_into(*targets) as first:
        yield first
