"""No function of the library takes more than 10 parameters: settings travel as frozen dataclasses
grouped by concern (:mod:`fringe3d.reconstruct.settings`). Exempt by rule: the typer command
signatures of ``commands/`` (one parameter per flag) and compiled numba / CUDA kernels (flat
arrays are all they can take). There is no other exception: a function that needs one is listed
in ALLOWED with its reason (empty since issue 24's typed settings)."""
from __future__ import annotations

import ast
from pathlib import Path

import fringe3d

SRC = Path(fringe3d.__file__).parent
MOST = 10

#: "module/path.py:function" -> why it still takes more than MOST parameters.
ALLOWED: dict[str, str] = {}


def _count(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    a = fn.args
    n = len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs) + (a.vararg is not None) + (a.kwarg is not None)
    return n - 1 if a.args and a.args[0].arg in ("self", "cls") else n


def _exempt_by_rule(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    decorators = [ast.unparse(d) for d in fn.decorator_list]
    return any("jit" in d for d in decorators) or any(d.startswith("app.command") for d in decorators)


def functions_over_the_limit() -> dict[str, int]:
    """``"path.py:name" -> parameter count`` of every function over :data:`MOST` not exempt by rule."""
    found = {}
    for path in sorted(SRC.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and _count(node) > MOST \
                    and not _exempt_by_rule(node):
                found[f"{path.relative_to(SRC).as_posix()}:{node.name}"] = _count(node)
    return found


def test_no_function_takes_more_than_ten_parameters_but_the_listed_exceptions():
    over = functions_over_the_limit()
    assert set(over) <= set(ALLOWED), f"functions over {MOST} parameters: {sorted(set(over) - set(ALLOWED))}"


def test_the_exception_list_names_only_functions_still_over_the_limit():
    over = functions_over_the_limit()
    assert set(ALLOWED) <= set(over), f"no longer over {MOST} parameters, drop them: {sorted(set(ALLOWED) - set(over))}"


def test_the_sequence_chain_passes_settings_whole():
    from fringe3d.cluster.engine import reconstruct_capture_on_dask
    from fringe3d.commands.reconstruct import _sequence
    from fringe3d.reconstruct.sequence import prepare_sequence, reconstruct_sequence

    for fn in (_sequence, reconstruct_capture_on_dask, reconstruct_sequence, prepare_sequence):
        assert fn.__code__.co_argcount + fn.__code__.co_kwonlyargcount <= 8, fn.__qualname__
