"""A page as headless Chromium (from Debian; ``ws/setup`` installs it) leaves it after its scripts ran."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path


def dump_dom(page: Path, fragment: str) -> str:
    """The DOM of ``page`` opened at ``#fragment``, after four seconds of virtual time, as HTML."""
    chromium = shutil.which("chromium")
    assert chromium, "chromium is not installed: ws/setup installs it (apt-get install chromium)"
    done = subprocess.run(
        [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=4000", "--dump-dom",
         f"{page.resolve().as_uri()}#{fragment}"],
        capture_output=True, text=True, timeout=180,
    )  # fmt: skip
    assert done.returncode == 0 and "<body" in done.stdout, done.stderr[-2000:]
    return done.stdout
