"""The report page in a real headless browser: every figure decodes, nothing is logged as an
error, and the page lays out for a phone's width.

Chromium is driven over its DevTools protocol on a pipe (``--remote-debugging-pipe``: JSON
messages separated by NUL bytes on file descriptors 3 and 4), so the check needs nothing
but the standard library, sees every console message, uncaught exception and failed load
as it happens (not a log scraped afterwards), and waits for the page's load event rather
than for a guessed time. Without a browser the tests skip, saying which binaries they
looked for: install one with ``apt-get install chromium-headless-shell`` (Debian), or name
one in ``FEEDTUNE_BROWSER``.
"""

from __future__ import annotations

import base64
import contextlib
import json
import os
import select
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "tests" / "data"
#: browsers looked for, in order, after ``$FEEDTUNE_BROWSER`` (Debian's wrapper scripts
#: in /usr/bin run these binaries)
BROWSERS = ("/usr/lib/chromium/chromium-headless-shell", "chromium-headless-shell",
            "/usr/lib/chromium/chromium", "chromium", "chromium-browser", "google-chrome",
            "headless_shell")
#: the phone the page is laid out for: CSS pixels
PHONE_WIDTH, PHONE_HEIGHT = 375, 812
#: seconds to wait for the browser's answer to one command or for the page to load
TIMEOUT = 60.0


def find_browser() -> str | None:
    """The first browser binary found, or None."""
    for name in filter(None, (os.environ.get("FEEDTUNE_BROWSER"), *BROWSERS)):
        found = shutil.which(name)
        if found:
            return found
    return None


class Browser:
    """A headless Chromium and one page, over the DevTools protocol on a pipe."""

    def __init__(self, binary: str, profile: Path):
        to_browser, self._to_browser = os.pipe()
        self._from_browser, from_browser = os.pipe()

        def onto_3_and_4():  # the fds --remote-debugging-pipe reads and writes
            os.dup2(to_browser, 3)
            os.dup2(from_browser, 4)

        args = [binary, "--headless", "--remote-debugging-pipe", "--disable-gpu",
                "--no-first-run", "--no-default-browser-check", f"--user-data-dir={profile}"]
        if os.geteuid() == 0:
            args.append("--no-sandbox")  # Chromium refuses to run as root with its sandbox
        self.process = subprocess.Popen(
            args + ["about:blank"], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE, pass_fds=(3, 4, to_browser, from_browser),
            preexec_fn=onto_3_and_4, start_new_session=True)
        os.close(to_browser)
        os.close(from_browser)
        self._buffer, self._next_id, self.events = b"", 0, []
        target = self.call("Target.createTarget", url="about:blank")["targetId"]
        self.session = self.call("Target.attachToTarget", targetId=target,
                                 flatten=True)["sessionId"]

    def _receive(self, deadline: float) -> dict:
        while b"\0" not in self._buffer:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self._from_browser], [], [], left)[0]:
                raise TimeoutError("the browser did not answer in time")
            chunk = os.read(self._from_browser, 1 << 16)
            if not chunk:
                raise RuntimeError("the browser closed its pipe: "
                                   + self.process.stderr.read().decode(errors="replace")[-2000:])
            self._buffer += chunk
        message, self._buffer = self._buffer.split(b"\0", 1)
        return json.loads(message)

    def call(self, method: str, session: str | None = None, **params) -> dict:
        """Send one command; return its result (events meanwhile go to ``events``)."""
        self._next_id += 1
        message = {"id": self._next_id, "method": method, "params": params}
        if session:
            message["sessionId"] = session
        os.write(self._to_browser, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + TIMEOUT
        while True:
            answer = self._receive(deadline)
            if answer.get("id") == self._next_id:
                if "error" in answer:
                    raise RuntimeError(f"{method}: {answer['error']}")
                return answer["result"]
            self.events.append(answer)

    def page(self, method: str, **params) -> dict:
        return self.call(method, self.session, **params)

    def wait_for(self, event: str) -> dict:
        """The first ``event`` of the page (already received or coming)."""
        deadline = time.monotonic() + TIMEOUT
        seen = 0
        while True:
            for message in self.events[seen:]:
                if message.get("method") == event and message.get("sessionId") == self.session:
                    return message
            seen = len(self.events)
            self.events.append(self._receive(deadline))

    def errors(self) -> list[str]:
        """Every console error, uncaught exception and error log entry of the page so far."""
        found = []
        for message in self.events:
            method, params = message.get("method"), message.get("params", {})
            if method == "Runtime.consoleAPICalled" and params["type"] in ("error", "assert"):
                found.append("console: " + " ".join(str(a.get("value", a.get("description")))
                                                     for a in params["args"]))
            elif method == "Runtime.exceptionThrown":
                details = params["exceptionDetails"]
                found.append("exception: " + details.get("exception", {}).get(
                    "description", details.get("text", "")))
            elif method == "Log.entryAdded" and params["entry"]["level"] == "error":
                found.append(f"log ({params['entry']['source']}): {params['entry']['text']}")
        return found

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self.call("Browser.close")
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            os.killpg(self.process.pid, signal.SIGKILL)  # our own session's group only
            self.process.wait()
        os.close(self._to_browser)
        os.close(self._from_browser)
        self.process.stderr.close()


#: what the page reports about itself once loaded
INSPECT = """JSON.stringify({
  images: Array.from(document.images, i => ({alt: i.alt, complete: i.complete,
                                               width: i.naturalWidth, height: i.naturalHeight})),
  lang: document.documentElement.lang,
  innerWidth: window.innerWidth,
  scrollWidth: document.documentElement.scrollWidth
})"""


def open_page(browser: Browser, page: Path) -> tuple[dict, list[str]]:
    """Load ``page`` (file://) as a phone would and return what it says of itself and the
    errors logged while loading."""
    browser.events.clear()
    for domain in ("Runtime", "Log", "Page"):
        browser.page(f"{domain}.enable")
    browser.page("Emulation.setDeviceMetricsOverride", width=PHONE_WIDTH, height=PHONE_HEIGHT,
                 deviceScaleFactor=2, mobile=True)
    navigation = browser.page("Page.navigate", url=page.resolve().as_uri())
    assert "errorText" not in navigation, navigation
    browser.wait_for("Page.loadEventFired")
    state = browser.page("Runtime.evaluate", expression=INSPECT, returnByValue=True)
    return json.loads(state["result"]["value"]), browser.errors()


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    binary = find_browser()
    if binary is None:
        pytest.skip("no headless browser found (looked for $FEEDTUNE_BROWSER, "
                    + ", ".join(BROWSERS) + "); on Debian: apt-get install "
                    "chromium-headless-shell")
    running = Browser(binary, tmp_path_factory.mktemp("chromium-profile"))
    yield running
    running.close()


def feedtune(*args: str) -> None:
    proc = subprocess.run([sys.executable, "-m", "feedtune", *args], capture_output=True,
                          timeout=300, cwd=REPO)
    assert proc.returncode == 0, proc.stderr.decode()


@pytest.fixture(scope="module")
def reports(tmp_path_factory):
    """Report directories: the stored results (Bhatia's hydraulic and Ward-Leonard drives,
    Tian's pulse generator) and Koren's example tuned now (4 s), for its circle figure."""
    root = tmp_path_factory.mktemp("reports")
    out = {}
    for name in ("bhatia-1971-hydraulic", "ward-leonard-feed-drive", "tian-vf-pulse"):
        out[name] = root / name
        feedtune("report", "-q", str(DATA / f"{name}.result.json"), "--out", str(out[name]))
    out["koren"] = root / "koren"
    feedtune("tune", "-q", str(REPO / "examples" / "koren-1979-sampled-data.json"), "-o",
             str(root / "koren.json"), "--report", str(out["koren"]))
    return out


@pytest.mark.parametrize("name", ["bhatia-1971-hydraulic", "ward-leonard-feed-drive",
                                  "tian-vf-pulse", "koren"])
def test_every_figure_loads_without_an_error_on_a_phone(browser, reports, name):
    directory = reports[name]
    state, errors = open_page(browser, directory / "report.html")
    assert errors == []
    pngs = sorted(directory.glob("*.png"))
    assert len(state["images"]) == len(pngs) >= 1  # one <img> per figure written
    for image in state["images"]:
        assert image["complete"] and image["width"] > 0 and image["height"] > 0, image
    assert state["lang"] == "en"
    assert state["innerWidth"] == PHONE_WIDTH  # the viewport meta: laid out at 375 px,
    assert state["scrollWidth"] <= PHONE_WIDTH  # not 980, and nothing wider than the screen


def test_a_broken_figure_or_a_script_error_is_caught(browser, tmp_path):
    """The check itself: a page with an undecodable image and a console error fails it."""
    good = base64.b64encode((REPO / "tests" / "data").joinpath(
        "bhatia-1971-hydraulic.result.json").read_bytes()[:64]).decode()
    page = tmp_path / "broken.html"
    page.write_text('<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"></head><body>'
                    f'<img alt="not a png" src="data:image/png;base64,{good}">'
                    '<script>console.error("drawn wrong")</script></body></html>')
    state, errors = open_page(browser, page)
    assert state["images"] == [{"alt": "not a png", "complete": True, "width": 0, "height": 0}]
    assert any("drawn wrong" in e for e in errors)
    assert state["innerWidth"] != PHONE_WIDTH  # no viewport meta: laid out wider
