"""The README's Python example (examples/quickstart.py) runs and its error matches the noise floor."""
import math
import re
import subprocess
import sys
from pathlib import Path

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "quickstart.py"


def test_quickstart_runs_and_reaches_the_n_step_noise_floor():
    out = subprocess.run([sys.executable, str(EXAMPLE)], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    m = re.search(r"phase RMS error ([\d.]+) rad, fringe-order errors ([\d.]+)%, valid pixels ([\d.]+)%", out.stdout)
    assert m, out.stdout
    rms, order_err, valid = (float(g) for g in m.groups())
    # 9-step phase noise sqrt(2/N) * sigma / B (the N-step noise floor): sigma = 2 grey levels plus 8-bit rounding
    # (variance 1/12), B = 180/2 = 90
    predicted = math.sqrt(2 / 9) * math.sqrt(2.0 ** 2 + 1 / 12) / 90
    assert abs(rms - predicted) < 0.1 * predicted
    assert order_err == 0.0 and valid == 100.0


def test_readme_shows_exactly_the_quickstart_script():
    readme = (EXAMPLE.parents[1] / "README.md").read_text()
    body = EXAMPLE.read_text().split('"""', 2)[2].strip()
    assert body in readme


def test_readme_opens_with_the_two_setup_commands():
    lines = [ln for ln in (EXAMPLE.parents[1] / "README.md").read_text().splitlines() if ln.strip()]
    assert lines[1] == "```sh"
    assert lines[2].startswith("make demo") and lines[3].startswith("make test") and lines[4] == "```"
    ci = (EXAMPLE.parents[1] / ".ci" / "run").read_text()
    assert "make test" in ci
