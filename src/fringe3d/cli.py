"""The ``fringe3d`` command.

Each sub-command lives in its own module under :mod:`fringe3d.commands` and exposes
``register(app)``; :data:`fringe3d.commands.lazy.COMMANDS` lists them in order, and a module is
imported only when its command runs (``--help`` and ``--version`` import none), so the command
starts in a blink. A command module that fails to import fails that command loudly instead of
vanishing from the CLI.

Exit codes (documented in ``fringe3d --help``):
  0 success · 1 unexpected internal error (a bug: the message says where to report it;
  ``fringe3d --debug ...`` shows the traceback) · 2 bad input or usage (the message says what was
  wrong and what was expected) · 3 an output could not be written · 4 a capture stopped or
  lost frames (the folder is not marked complete) · 130 interrupted (Ctrl-C).
"""
from __future__ import annotations

import signal
import sys
import warnings

import typer
from rich.markup import escape

from fringe3d.commands.lazy import LazyCommands
from fringe3d.commands.flag_words import in_flag_words
from fringe3d.gpu.runtime import CudaUnavailableError
from fringe3d.utils.console import err_console, set_quiet, settings, warn
from fringe3d.utils.output_folder import (
    BusyOutputError,
    interrupt_requested,
    output_note,
    request_interrupt,
    set_command_line,
)
from fringe3d.utils.warning_types import Fringe3DWarning

EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT, EXIT_WRITE, EXIT_INTERRUPTED = 0, 1, 2, 3, 130
ISSUES_URL = "https://github.com/fringe3d/fringe3d/issues"


class _Flags:
    debug = False

app = typer.Typer(
    name="fringe3d",
    help=(
        "Superfast, high-accuracy 3D shape measurement with digital fringe projection, "
        "and a virtual camera-projector rig with ground truth.\n\n"
        "Exit codes: 0 ok, 1 internal error, 2 bad input or usage, 3 output not writable, "
        "4 capture incomplete, 130 interrupted.\n\n"
        "Example: fringe3d demo -o demo-out"
    ),
    no_args_is_help=True,
    cls=LazyCommands,
    add_completion=True,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", help="Print the fringe3d version and exit.", is_eager=True,
                                 callback=lambda v: _print_version(v)),
    debug: bool = typer.Option(False, "--debug", help="Show the Python traceback of an internal error."),
) -> None:
    """Superfast, high-accuracy 3D shape measurement with digital fringe projection."""
    _Flags.debug = debug


def _print_version(value: bool) -> None:
    if value:
        from fringe3d import __version__

        typer.echo(__version__)
        raise typer.Exit()


def show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """``warnings.showwarning`` of the CLI: fringe3d's warnings as ``warning: <message>`` lines
    on stderr, any other warning as Python shows it."""
    if issubclass(category, Fringe3DWarning):
        text = in_flag_words(str(message))
        _repeats[text] = _repeats.get(text, 0) + 1
        if _repeats[text] == 1:  # a repeat is counted, and reported once at the end
            warn(text)
    else:
        _python_showwarning(message, category, filename, lineno, file, line)


_python_showwarning = warnings.showwarning
#: fringe3d warning text -> times raised in this command (each shown once, repeats counted)
_repeats: dict[str, int] = {}


def _report_repeats() -> None:
    """One ``warning: ... (N times in all)`` line for each warning raised more than once."""
    for text, n in _repeats.items():
        if n > 1:
            short = text if len(text) <= 80 else text[:77] + "..."
            warn(f"the warning \"{short}\" was raised {n} times in all (shown once)")
    _repeats.clear()


def _interrupted() -> int:
    """Message and exit code of Ctrl-C: how far the command got and how to go on."""
    where = ""
    if settings.progress is not None:
        what, done, total = settings.progress
        where = f"; {done} of {total} done ({what})" if total else f"; {done} done ({what})"
    note = output_note() or "Nothing unfinished is marked complete"
    err_console.print(f"[bold red]interrupted[/]{escape(where)}. {escape(in_flag_words(note))}.")
    return EXIT_INTERRUPTED


def _with_note(message: str) -> str:
    """``message`` and, when an output block did not finish, what became of its output."""
    note = output_note()
    return in_flag_words(f"{message}. {note}" if note else message)


def _internal(e: BaseException) -> int:
    if _Flags.debug:
        err_console.print_exception()
    err_console.print(f"[bold red]internal error:[/] {escape(type(e).__name__)}: {escape(str(e))}. This is a bug "
                      f"in fringe3d, not in your input: please report it at {ISSUES_URL} with the command line "
                      "(run it again with `fringe3d --debug ...` for the traceback).")
    return EXIT_INTERNAL


def _from_ctrl_c(e: BaseException) -> bool:
    """Whether ``e`` was caused by a Ctrl-C: a ``KeyboardInterrupt`` raised where C code (numba's
    dispatcher, a C callback) could only report it as "returned a result with an exception set"."""
    seen = set()
    while e is not None and id(e) not in seen:
        if isinstance(e, KeyboardInterrupt):
            return True
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return False


def _on_sigint(signum, frame) -> None:
    request_interrupt()
    raise KeyboardInterrupt


def _unraisable(hook):
    """``sys.unraisablehook`` that stays silent about a Ctrl-C raised inside a C callback (numba's
    compiler): the interrupt is recorded and reported once, without a stray traceback."""
    def quiet(u) -> None:
        if u.exc_type is not None and issubclass(u.exc_type, KeyboardInterrupt):
            return
        hook(u)
    return quiet


def main(argv: list[str] | None = None) -> int:
    """Entry point: run the app, turning known error types into clear messages and exit codes."""
    request_interrupt(False)
    output_note(clear=True)
    try:
        previous = signal.signal(signal.SIGINT, _on_sigint)
    except ValueError:  # not the main thread: keep Python's handler
        previous = None
    hook, sys.unraisablehook = sys.unraisablehook, _unraisable(sys.unraisablehook)
    try:
        return _run(argv)
    finally:
        sys.unraisablehook = hook
        if previous is not None:
            signal.signal(signal.SIGINT, previous)


def _run(argv: list[str] | None) -> int:
    set_quiet(False)  # the command line shows progress; sub-commands' --quiet/--json silence it
    settings.progress = None
    _Flags.debug = False
    set_command_line(list(sys.argv[1:] if argv is None else argv))
    try:
        _repeats.clear()
        with warnings.catch_warnings():
            warnings.showwarning = show_warning
            try:
                rc = app(args=argv, standalone_mode=False)
            finally:
                _report_repeats()
        if rc == EXIT_INTERRUPTED:  # typer turns Ctrl-C into Exit(130) and returns the code
            return _interrupted()
        if isinstance(rc, int) and not isinstance(rc, bool) and rc != 0:
            return rc
        if interrupt_requested():  # a Ctrl-C that a C callback swallowed
            return _interrupted()
    except SystemExit as e:  # typer/click exit
        return int(e.code or 0)
    except KeyboardInterrupt:
        return _interrupted()
    except (ValueError, FileNotFoundError, KeyError, NotADirectoryError, IsADirectoryError, CudaUnavailableError) as e:
        if interrupt_requested():  # what Ctrl-C cut short is not an input error
            return _interrupted()
        err_console.print(f"[bold red]error:[/] {escape(_with_note(str(e)))}")
        return EXIT_BAD_INPUT
    except MemoryError:
        err_console.print("[bold red]error:[/] not enough memory for this input; use smaller frames, fewer cycles "
                          "(--max-cycles) or a machine with more memory")
        return EXIT_BAD_INPUT
    except BusyOutputError as e:  # another live run holds the output: nothing to overwrite or clean
        err_console.print(f"[bold red]output busy:[/] {escape(str(e))}")
        return EXIT_WRITE
    except PermissionError as e:
        err_console.print(f"[bold red]cannot write output:[/] {escape(_with_note(str(e)))}")
        return EXIT_WRITE
    except OSError as e:
        if interrupt_requested():
            return _interrupted()
        err_console.print(f"[bold red]I/O error:[/] {escape(_with_note(str(e)))}")
        return EXIT_WRITE
    except Exception as e:  # usage errors of typer's (vendored) click, and the rest
        if interrupt_requested() or _from_ctrl_c(e):  # e.g. SystemError of a compiled kernel that Ctrl-C cut
            return _interrupted()
        if hasattr(e, "show") and hasattr(e, "exit_code"):  # ClickException / UsageError
            e.show()
            return EXIT_BAD_INPUT
        if type(e).__name__ == "Abort" and isinstance(e.__cause__, EOFError):  # click turns EOFError into Abort
            err_console.print(f"[bold red]error:[/] a file ended before its data did (empty or truncated): "
                              f"{escape(str(e.__cause__) or 'end of file')}")
            return EXIT_BAD_INPUT
        if type(e).__name__ == "Abort":  # click turns Ctrl-C into Abort
            return _interrupted()
        return _internal(e)
    return EXIT_OK


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
