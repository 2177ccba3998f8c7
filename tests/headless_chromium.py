"""Debian's Chromium for the browser tests (``make test`` installs it through
scripts/ensure-system-packages.sh; a missing Chromium is a failure, not a skip)."""
import shutil

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
#: Headless, no sandbox (root in CI), no GPU, and nothing that reaches the network.
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def launch(playwright):
    """A headless Chromium browser from a ``sync_playwright()`` context."""
    assert CHROMIUM, "Debian's chromium is missing: `make test` installs it (scripts/ensure-chromium.sh)"
    return playwright.chromium.launch(executable_path=CHROMIUM, args=ARGS)
