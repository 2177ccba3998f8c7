"""The same seeded demo gives the same files twice, apart from wall-clock times."""
from __future__ import annotations

import json
import re

from fringe3d.cli import main

COMMAND = re.compile(rb"comment command: [^\n]*\n")
TIMES = re.compile(r"<h2>Time per stage</h2>.*?</table>", re.S)
# the provenance table's rows that name the run: its command line (another -o folder) and start time
RUN_ROWS = re.compile(r"<tr><td>(command|started)</td><td>[^<]*</td></tr>")


def _without_times(name: str, data: bytes) -> bytes:
    if name.endswith(".json") and name != "fringe3d.json":  # provenance: when and by which command line
        d = json.loads(data)
        for key in ("written", "command"):  # the runs write to different folders
            d.get("provenance", {}).pop(key, None)
        data = json.dumps(d).encode()
    if name.endswith(".ply"):
        data = COMMAND.sub(b"", data)
    if name == "fringe3d.json":  # the completion marker: start and finish times, file sizes
        d = json.loads(data)
        return json.dumps({k: v for k, v in d.items() if k not in ("started", "finished", "files", "command")}).encode()
    if name == "summary.json":
        d = json.loads(data)
        d.pop("seconds_total", None)
        for stage in d.get("stages", []):
            stage.pop("seconds", None)
        return json.dumps(d, sort_keys=True).encode()
    if name == "report.html":
        return RUN_ROWS.sub("", TIMES.sub("", data.decode())).encode()
    return data


def test_demo_with_one_seed_twice_gives_identical_files_apart_from_timings(tmp_path):
    runs = []
    for i in range(2):
        out = tmp_path / f"demo{i}"
        assert main(["demo", "--profile", "tiny", "--seed", "0", "-o", str(out), "-q"]) == 0
        runs.append({p.relative_to(out).as_posix(): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()})
    assert runs[0].keys() == runs[1].keys() and len(runs[0]) >= 10
    differing = [n for n in runs[0] if _without_times(n, runs[0][n]) != _without_times(n, runs[1][n])]
    assert differing == []
