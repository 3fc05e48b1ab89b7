"""What a user opens, opened in headless Chromium (Debian's chromium + chromium-driver; .ci/run
installs them when it runs as root, and these tests skip, saying so, where they are missing):
the replays, the uncertainty report and a Snakemake report holding both render something (a
screenshot that is not one flat colour) with no console error, and every result the Snakemake
report embeds is under the 2 MiB Chromium opens as a data URI.

The pages are built here from small inputs, so the tests need no `make figures`; the last test
also opens the repository's own Snakemake report when `make figures` has left results/ behind.
"""
from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from chromium import Browser, blank, missing
from conftest import REPO

pytestmark = [pytest.mark.slow, pytest.mark.skipif(bool(missing()), reason=missing())]
ROBOBALL = [sys.executable, "-m", "roboball.cli", "stage"]
SNAKEMAKE = str(Path(sys.executable).with_name("snakemake"))
LIMIT = 2 * 1024 * 1024


def _stage(*args):
    r = subprocess.run(ROBOBALL + [str(a) for a in args], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    """The replays (two kinds: enough to show the gallery's layout), their shared viewer and
    gallery, and an uncertainty report from the unit tests' inputs."""
    d = tmp_path_factory.mktemp("pages")
    reg = d / "shell_regression.csv"
    reg.write_text("name,value\nzeta_a,0.23\nzeta_b,-0.0386\nomega_n_c,2.70\nomega_n_d,0.0276\n")
    (d / "replays").mkdir()
    _stage("replay-viewer", "--out-js", d / "replays" / "meshcat.js")
    for kind, contact, release in (("ramp", "hydroelastic", 0.0), ("steer_stand", "point", 0.8)):
        _stage("replay", "--kind", kind, "--contact", contact, "--regression", reg, "--release", release,
               "--duration", 2.0, "--out-html", d / "replays" / f"{kind}.html",
               "--out-scene", d / "replays" / f"{kind}.scene.json")
    _stage("replay-gallery", "--scenes", d / "replays" / "ramp.scene.json", d / "replays" / "steer_stand.scene.json",
           "--viewer", d / "replays" / "meshcat.js", "--out-html", d / "replays" / "index.html")
    from test_uncertainty import _report
    (d / "unc").mkdir()
    _report(d / "unc", ramp_friction=["majd.json"])
    return d


def _check(browser: Browser, url: str, settle_s: float = 3.0):
    """Open `url`; the screenshot must not be blank, the console must hold no error."""
    browser.open(url, settle_s)
    shot = browser.screenshot()
    errors = browser.console_errors()
    assert not blank(shot), f"{url}: blank page"
    assert not errors, f"{url}: console errors {errors}"
    return shot


def test_replay_page_and_gallery_render(pages):
    with Browser() as b:
        _check(b, (pages / "replays" / "ramp.html").as_uri())
        assert b.run("return document.querySelectorAll('canvas').length") == 1
        assert "Ramp descent" in b.run("return document.body.innerText")
        _check(b, (pages / "replays" / "index.html").as_uri(), settle_s=5.0)
        assert b.run("return document.querySelectorAll('canvas').length") == 2      # both viewers came up


def test_uncertainty_report_renders_with_its_red_flags(pages):
    with Browser() as b:
        _check(b, (pages / "unc" / "report.html").as_uri(), settle_s=1.0)
        text = b.run("return document.body.innerText")
        assert "Red flags (3)" in text and "Contents" in text
        assert b.run("return getComputedStyle(document.querySelector('tr.bad td')).color") == "rgb(187, 0, 0)"


def _snakemake_report(workdir: Path, out: Path) -> dict:
    """`snakemake --report` in `workdir`; its results (path -> entry with the data URI)."""
    r = subprocess.run([SNAKEMAKE, "--cores", "1", "--report", str(out)], cwd=workdir, capture_output=True,
                       text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    m = re.search(r"\bresults = (\{.*?\});?\s*$", out.read_text(encoding="utf-8"), re.M)
    return json.loads(m.group(1)) if m else {}


def _check_report(b: Browser, report: Path, results: dict) -> list:
    """Open the report, then each HTML result the way the report shows it (an iframe on its data
    URI); every one under 2 MiB, rendered, without console errors.  Returns the checked paths."""
    _check(b, report.as_uri(), settle_s=2.0)
    checked = []
    for path, entry in results.items():
        if entry["mime_type"] != "text/html":
            continue
        assert len(entry["data_uri"]) < LIMIT, f"{path}: {len(entry['data_uri'])} characters as a data URI"
        b.run("""const f = document.createElement('iframe');
                 f.style = 'position:fixed;left:0;top:0;width:100vw;height:100vh;border:0;z-index:99;background:#fff';
                 document.querySelectorAll('iframe.check').forEach(e => e.remove());
                 f.className = 'check'; f.src = arguments[0]; document.body.appendChild(f);""", entry["data_uri"])
        time.sleep(5.0)
        shot = b.screenshot()
        assert not blank(shot, (0, 0, shot.width, shot.height)), f"{path}: blank in the report"
        assert not b.console_errors(), f"{path}: console errors"
        assert b.run("return document.querySelector('iframe.check').contentDocument === null")   # data URI: opaque
        checked.append(path)
    return checked


def test_a_snakemake_report_shows_the_replays_and_the_report(pages, tmp_path):
    """A two-rule workflow marking the gallery and the uncertainty report for its report, as the
    pipeline's rules do: both must open from the report."""
    (tmp_path / "in").mkdir()
    shutil.copy(pages / "replays" / "index.html", tmp_path / "in" / "gallery.html")
    shutil.copy(pages / "unc" / "report.html", tmp_path / "in" / "unc.html")
    (tmp_path / "cap.rst").write_text("A result.\n")
    (tmp_path / "Snakefile").write_text(
        'rule all:\n    input: "out/gallery.html", "out/unc.html"\n\n'
        'rule copy:\n    input: "in/{name}.html"\n'
        '    output: report("out/{name}.html", category="pages", caption="cap.rst", labels={"page": "{name}"})\n'
        '    shell: "cp {input} {output}"\n')
    r = subprocess.run([SNAKEMAKE, "--cores", "1"], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    report = tmp_path / "report.html"
    results = _snakemake_report(tmp_path, report)
    with Browser() as b:
        assert sorted(_check_report(b, report, results)) == ["out/gallery.html", "out/unc.html"]


def test_the_repositorys_own_snakemake_report(tmp_path):
    """After `make figures`: the pipeline's own report, every embedded HTML result under 2 MiB
    and rendered (the uncertainty report, the replays, the tables)."""
    if not (REPO / "results" / "replays" / "index.html").is_file() or not (REPO / ".snakemake").is_dir():
        pytest.skip("no results of `make figures` in the repository: run it first to check its own report")
    report = tmp_path / "report.html"
    results = _snakemake_report(REPO, report)
    with Browser() as b:
        checked = _check_report(b, report, results)
    assert "results/replays/index.html" in checked and "paper_figures/uncertainty_report.html" in checked
    assert any(p.startswith("results/report/table") for p in checked)
