"""A minimal WebDriver client for Debian's headless Chromium (chromium + chromium-driver), over
plain HTTP with requests: open a page, run a script, take a screenshot, read the console.  The
browser tests use it; without the packages they skip, saying how to install them."""
from __future__ import annotations

import base64
import io
import shutil
import socket
import subprocess
import tempfile
import time

import requests

CHROMIUM = "/usr/bin/chromium"
# Chromium as root in a container: no sandbox, no GPU (WebGL on SwiftShader), nothing from the network.
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--enable-unsafe-swiftshader", "--window-size=1400,900"]


def missing() -> str:
    """Why no browser test can run here ("" when it can)."""
    if not shutil.which("chromedriver") or not shutil.which(CHROMIUM):
        return ("no headless Chromium: install Debian's chromium and chromium-driver "
                "(apt-get install chromium chromium-driver; .ci/run does when it runs as root)")
    return ""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Browser:
    """One Chromium session driven through chromedriver (a context manager)."""

    def __init__(self):
        self.port = _free_port()
        self.profile = tempfile.mkdtemp(prefix="roboball-chromium-")    # a fresh user data dir
        self.driver = subprocess.Popen(["chromedriver", f"--port={self.port}"], stdout=subprocess.DEVNULL,
                                       stderr=subprocess.DEVNULL)
        self.url = f"http://127.0.0.1:{self.port}"
        for _ in range(100):
            try:
                requests.get(self.url + "/status", timeout=1)
                break
            except requests.ConnectionError:
                time.sleep(0.1)
        caps = {"browserName": "chrome", "goog:loggingPrefs": {"browser": "ALL"},
                "goog:chromeOptions": {"binary": CHROMIUM, "args": FLAGS + [f"--user-data-dir={self.profile}"]}}
        r = requests.post(self.url + "/session", json={"capabilities": {"alwaysMatch": caps}}, timeout=60).json()
        self.session = f"{self.url}/session/{r['value']['sessionId']}"

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        try:
            requests.delete(self.session, timeout=30)
        finally:
            self.driver.terminate()
            self.driver.wait(timeout=30)
            shutil.rmtree(self.profile, ignore_errors=True)

    def open(self, url: str, settle_s: float = 2.0) -> None:
        requests.post(self.session + "/url", json={"url": url}, timeout=120).raise_for_status()
        time.sleep(settle_s)

    def run(self, script: str, *args):
        r = requests.post(self.session + "/execute/sync", json={"script": script, "args": list(args)}, timeout=120)
        r.raise_for_status()
        return r.json()["value"]

    def screenshot(self):
        """The viewport as a PIL image."""
        from PIL import Image

        data = requests.get(self.session + "/screenshot", timeout=120).json()["value"]
        return Image.open(io.BytesIO(base64.b64decode(data))).convert("RGB")

    def console_errors(self) -> list:
        """The console's errors since the last call (uncaught exceptions, failed loads)."""
        r = requests.post(self.session + "/se/log", json={"type": "browser"}, timeout=60).json()["value"]
        return [e["message"] for e in r if e.get("level") == "SEVERE"]


def blank(image, box=None) -> bool:
    """True when the image (or its `box`) is one flat colour: nothing rendered."""
    from PIL import ImageStat

    part = image.crop(box) if box else image
    return max(ImageStat.Stat(part).stddev) < 2.0
