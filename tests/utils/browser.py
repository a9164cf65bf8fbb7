"""Factory: a real headless Chromium (Debian's `chromium` + `chromium-driver`) driven by Selenium.

`scripts/system-packages.sh` installs both (make test runs it). `browser_or_skip()` skips with the
reason when Selenium, the browser or its driver is missing; a browser that is present but fails to
start is a test error, not a skip.

The flags keep Chromium from reaching for the network (this machine has none: without them it waits
on refused connections) and let it run as root in a container; each browser gets a fresh profile.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from pathlib import Path
from typing import Any

import pytest

CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-dev-shm-usage",
    "--window-size=1400,1000",
)


def _program(path: Path, name: str) -> Path | None:
    if path.is_file():
        return path
    found = shutil.which(name)
    return Path(found) if found else None


def browser_or_skip() -> tuple[Any, Path]:
    """A started Chrome WebDriver and its profile folder; skips (with why) if it cannot exist here."""
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        pytest.skip("selenium is not installed (pip install -e '.[dev]')")
    chromium = _program(CHROMIUM, "chromium")
    driver = _program(CHROMEDRIVER, "chromedriver")
    if chromium is None or driver is None:
        missing = [n for n, p in (("chromium", chromium), ("chromium-driver", driver)) if p is None]
        pytest.skip(
            f"no headless browser: Debian package(s) {', '.join(missing)} missing "
            "(bash scripts/system-packages.sh installs them)"
        )
    profile = Path(tempfile.mkdtemp(prefix="dualsys-chromium-"))
    options = webdriver.ChromeOptions()
    options.binary_location = str(chromium)
    for flag in FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={profile}")
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    browser = webdriver.Chrome(service=Service(str(driver)), options=options)
    browser.set_page_load_timeout(60)
    return browser, profile


def console_errors(browser: Any, *, allow: tuple[str, ...] = ()) -> list[str]:
    """The page's console errors since the last call (CSP violations and script errors land here)."""
    messages = [entry["message"] for entry in browser.get_log("browser") if entry["level"] == "SEVERE"]
    return [m for m in messages if not any(a in m for a in allow)]


def page_data(browser: Any) -> dict[str, Any]:
    return json.loads(browser.find_element("id", "page-data").get_attribute("textContent"))
