"""fringe3d.utils.freed_memory: freed image buffers are reused, not faulted in again."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

from fringe3d.utils import freed_memory

# Allocates and frees a 48 MiB float64 array ten times, before and after keep_freed_memory(),
# and prints the minor page faults (the kernel's own counter) of each round of ten.
_PROBE = textwrap.dedent("""
    import json, resource, numpy as np
    from fringe3d.utils.freed_memory import keep_freed_memory
    def faults():
        r0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        for _ in range(10):
            a = np.ones(6 * 2**20)
            del a
        return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - r0
    before = [faults(), faults()]
    kept = keep_freed_memory()
    after = [faults(), faults()]
    print(json.dumps({"before": before, "kept": kept, "again": keep_freed_memory(), "after": after}))
""")


def _probe(**env: str) -> dict:
    run = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, check=True,
                         env={**os.environ, **env})
    return json.loads(run.stdout)


def test_kept_memory_makes_repeated_large_allocations_fault_free():
    probe = _probe()
    if freed_memory._glibc() is None:  # another C library: nothing is changed, and it says so
        assert probe["kept"] is False and probe["again"] is False
        return
    assert probe["kept"] is True and probe["again"] is True
    # glibc's default returns a 48 MiB block to the kernel at every free: it faults back in
    assert min(probe["before"]) >= 10
    # once kept, the second round of ten reuses the first round's memory: no fault at all
    assert probe["after"][1] <= 2
    assert probe["after"][1] * 10 <= min(probe["before"])


def test_opt_out_variable_leaves_the_defaults():
    probe = _probe(**{freed_memory.OPT_OUT_VARIABLE: "1"})
    assert probe["kept"] is False
    assert min(probe["after"]) >= 10  # still faulted in at every allocation
