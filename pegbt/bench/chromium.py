"""Debian's chromium, headless, as every browser check of pegbt drives it through Playwright (the monitor's
benchmark, its browser tests, the documentation's pictures): never a browser Playwright downloads."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from playwright.sync_api import Browser, Playwright

CHROMIUM = "/usr/bin/chromium"  # Debian's package (`dev/setup test` installs it)
FLAGS = (
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
)  # no sandbox, GPU or background traffic: a container's headless run, on loopback only


def headless_chromium(playwright: Playwright) -> Browser:
    """Debian's chromium launched headless by `playwright`."""
    return playwright.chromium.launch(executable_path=CHROMIUM, headless=True, args=list(FLAGS))
