"""A private Xvfb X server for the device tests (``make test`` installs Xvfb through
scripts/ensure-system-packages.sh; a missing Xvfb is a failure, not a skip)."""
import os
import shutil
import subprocess
import time
from pathlib import Path

import pytest

#: The virtual screen: the tiny preset's projector size.
SCREEN = (256, 200)


def _free_display() -> int:
    for n in range(90, 200):
        if not Path(f"/tmp/.X11-unix/X{n}").exists() and not Path(f"/tmp/.X{n}-lock").exists():
            return n
    raise RuntimeError("no free X display number in :90..:199")


@pytest.fixture(scope="session")
def xvfb():
    """Start ``Xvfb :N -screen 0 256x200x24`` and point DISPLAY at it; yields ":N"."""
    exe = shutil.which("Xvfb")
    if exe is None:
        pytest.fail("Xvfb is not installed: run 'bash scripts/ensure-system-packages.sh' (make test does) or "
                    "'apt-get install xvfb'; the window-projector tests need an X server", pytrace=False)
    n = _free_display()
    proc = subprocess.Popen([exe, f":{n}", "-screen", "0", f"{SCREEN[0]}x{SCREEN[1]}x24", "-nolisten", "tcp"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    sock = Path(f"/tmp/.X11-unix/X{n}")
    for _ in range(200):
        if sock.exists() or proc.poll() is not None:
            break
        time.sleep(0.05)
    if proc.poll() is not None or not sock.exists():
        err = proc.stderr.read().decode(errors="replace") if proc.poll() is not None else ""
        proc.kill()
        pytest.fail(f"Xvfb :{n} did not start: {err[-500:]}", pytrace=False)
    old = os.environ.get("DISPLAY")
    os.environ["DISPLAY"] = f":{n}"
    yield f":{n}"
    if old is None:
        os.environ.pop("DISPLAY", None)
    else:
        os.environ["DISPLAY"] = old
    proc.terminate()
    try:
        proc.wait(5)
    except subprocess.TimeoutExpired:
        proc.kill()


def screenshot(display: str):
    """The X server's framebuffer of the default screen, (H, W, 3) uint8 (XCB GetImage via Pillow)."""
    import numpy as np
    from PIL import ImageGrab
    return np.asarray(ImageGrab.grab(xdisplay=display).convert("RGB"))
