"""A private Xvfb X server for the device tests (``make test`` installs Xvfb through
scripts/ensure-system-packages.sh; a missing Xvfb is a failure, not a skip)."""
import os
import select
import shutil
import subprocess
import time
from pathlib import Path

import pytest

#: The virtual screen: the tiny preset's projector size.
SCREEN = (256, 200)


def _read_display(fd: int, proc: subprocess.Popen, wait: float = 60.0) -> str:
    """The display number Xvfb writes to ``fd`` (``-displayfd``), "" if it exits or is silent."""
    got = b""
    deadline = time.monotonic() + wait
    while not got.endswith(b"\n") and time.monotonic() < deadline:
        ready, _, _ = select.select([fd], [], [], 0.1)
        if ready:
            chunk = os.read(fd, 16)
            if not chunk:
                break
            got += chunk
        elif proc.poll() is not None:
            break
    return got.decode().strip() if got.endswith(b"\n") else ""


@pytest.fixture(scope="session")
def xvfb():
    """Start ``Xvfb -displayfd FD -screen 0 256x200x24`` and point DISPLAY at it; yields ":N".

    ``-displayfd``: the server takes the first free display number itself (under its lock file), so
    parallel test processes (pytest -n) and other sessions never race for one."""
    exe = shutil.which("Xvfb")
    if exe is None:
        pytest.fail("Xvfb is not installed: run 'bash scripts/ensure-system-packages.sh' (make test does) or "
                    "'apt-get install xvfb'; the window-projector tests need an X server", pytrace=False)
    read_fd, write_fd = os.pipe()
    proc = subprocess.Popen([exe, "-displayfd", str(write_fd), "-screen", "0", f"{SCREEN[0]}x{SCREEN[1]}x24",
                             "-nolisten", "tcp"], pass_fds=(write_fd,), stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)
    os.close(write_fd)
    n = _read_display(read_fd, proc)
    os.close(read_fd)
    sock = Path(f"/tmp/.X11-unix/X{n}")
    if not n or proc.poll() is not None or not sock.exists():
        proc.kill()
        err = proc.stderr.read().decode(errors="replace")
        pytest.fail(f"Xvfb did not start (display {n!r}): {err[-500:]}", pytrace=False)
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
