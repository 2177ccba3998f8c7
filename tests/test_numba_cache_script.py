"""scripts/numba_cache.py (make test's wrapper): numba's compiled kernels are carried into a clone
in another folder only when every file of the package is the same, and stale ones never survive."""
from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "numba_cache.py"

KERNEL = """import numba


@numba.njit(cache=True)
def twice(x):
    return 2.0 * x
"""

# Calls the kernel and writes how many of its signatures numba loaded from the cache.
CALL = ("import sys; sys.path.insert(0, 'src'); from fringe3d import k; assert k.twice(1.5) == 3.0; "
        "open('hits.txt', 'w').write(str(sum(k.twice.stats.cache_hits.values())))")


@pytest.fixture
def script(monkeypatch, tmp_path):
    """The script as a module, on a fake package ``tmp_path/repo/src/fringe3d`` and store."""
    spec = importlib.util.spec_from_file_location("numba_cache_under_test", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    package = tmp_path / "repo" / "src" / "fringe3d"
    (package / "__pycache__").mkdir(parents=True)
    (package / "__init__.py").write_text("")  # a regular package: found before the installed fringe3d
    (package / "k.py").write_text(KERNEL)
    monkeypatch.setattr(module, "PACKAGE", package)
    monkeypatch.setenv("FRINGE3D_NUMBA_STORE", str(tmp_path / "store"))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    return module


def _fake_compile(package: Path, text: str) -> list[str]:
    """A command that writes numba-like cache files into the package tree."""
    code = (f"from pathlib import Path; p = Path({str(package / '__pycache__')!r}); "
            f"(p / 'k.twice-4.py311.nbi').write_text({text!r}); (p / 'k.twice-4.py311.1.nbc').write_text({text!r})")
    return [sys.executable, "-c", code]


def test_kernels_saved_by_one_run_are_restored_for_the_same_source_and_the_exit_code_passes_through(script):
    package = script.PACKAGE
    assert script.main(["--", *_fake_compile(package, "compiled")]) == 0
    for f in script.tree_kernels():
        f.unlink()
    assert script.main(["--", sys.executable, "-c", "import sys; sys.exit(3)"]) == 3
    assert (package / "__pycache__" / "k.twice-4.py311.nbi").read_text() == "compiled"


def test_a_change_to_any_package_file_restores_nothing_and_removes_the_stale_kernels_first(script):
    package = script.PACKAGE
    script.main(["--", *_fake_compile(package, "compiled")])
    (package / "other.py").write_text("X = 1\n")  # not the kernel's own file: numba alone would not notice
    seen = package.parent / "seen.txt"
    probe = f"import os; open({str(seen)!r}, 'w').write(str(sorted(os.listdir({str(package / '__pycache__')!r}))))"
    script.main(["--", sys.executable, "-c", probe])
    assert seen.read_text() == "[]"


def test_the_store_keeps_the_newest_snapshot_of_the_three_most_recent_sources(script):
    package = script.PACKAGE
    keys = []
    for i in range(5):
        (package / "k.py").write_text(KERNEL + f"# version {i}\n")
        for _ in range(2):
            script.main(["--", *_fake_compile(package, f"v{i}")])
        keys.append(script.source_key())
    store = script.store_root()
    kept = sorted(p.name.rsplit("-", 1)[0] for p in store.iterdir() if not p.name.startswith("."))
    assert kept == sorted(keys[-3:])


def test_a_clone_in_another_folder_loads_the_kernel_numba_compiled_and_a_changed_source_recompiles(script, tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["FRINGE3D_NUMBA_STORE"] = str(tmp_path / "store")
    first = tmp_path / "repo"
    (first / "scripts").mkdir()
    shutil.copy(SCRIPT, first / "scripts")

    def run(repo: Path) -> int:
        subprocess.run([sys.executable, "scripts/numba_cache.py", "--", sys.executable, "-c", CALL], cwd=repo,
                       env=env, check=True, capture_output=True)
        return int((repo / "hits.txt").read_text())

    assert run(first) == 0  # compiled, then saved
    clone = tmp_path / "clone"  # another folder, every file written anew (new times), no __pycache__
    shutil.copytree(first, clone, ignore=shutil.ignore_patterns("__pycache__", "hits.txt"))
    assert run(clone) == 1
    (clone / "src" / "fringe3d" / "__init__.py").write_text("# changed\n")
    assert run(clone) == 0
