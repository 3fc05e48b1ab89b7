"""Replay pages (roboball.report.replays): each replay's page loads the shared meshcat.js, the
gallery carries the viewer code once and refuses to outgrow the 2 MiB a browser opens as the
Snakemake report's data URI; captions say kind, contact, pressure and friction."""
from __future__ import annotations

import base64
import gzip
import json
import re

import pytest

from roboball.errors import RoboballError
from roboball.report.replays import DATA_URI_LIMIT, caption, data_uri_length, gallery_page, standalone_page

FACTS = {"kind": "ramp", "contact": "hydroelastic", "pressure_kpa": 13.8, "zeta": 0.135, "omega_n_rad_s": 3.08,
         "dissipation_scale": 0.5, "friction": "Majd law on steer and drive joints, Table I values",
         "ramp_angle_deg": 16.0, "ramp_length_m": 2.0, "release_rad": 0.0, "duration_s": 4.0}


def _scene(kind="ramp", contact="hydroelastic", commands=("AAAA",)):
    return {"facts": {**FACTS, "kind": kind, "contact": contact}, "commands": list(commands),
            "camera_m": [0.0, -2.0, 0.6], "target_m": [0.0, 0.0, 0.3], "follow": "/drake/visualizer/roboball/pitch_center"}


def test_caption_names_kind_contact_pressure_and_friction():
    title, text = caption(_scene()["facts"])
    assert title == "Ramp descent"
    for needle in ("hydroelastic contact", "13.8 kPa", "damping ratio 0.135", "Majd law", "16 deg ramp", "looping"):
        assert needle in text, needle
    _, stand = caption(_scene("steer_stand", "point")["facts"])
    assert "held by the stand" in stand and "kPa" not in stand


def test_a_replay_page_loads_the_shared_viewer_and_carries_no_copy():
    page = standalone_page(_scene())
    assert '<script src="meshcat.js"></script>' in page
    assert "three" not in page.lower() and len(page) < 20_000
    assert "Ramp descent" in page and "hydroelastic contact" in page


def test_the_gallery_carries_the_viewer_once_compressed():
    viewer = "var MeshCat = {};" + "/* three.js */" * 1000
    page = gallery_page([_scene(), _scene("shell_rock", "injected")], viewer)
    blobs = dict(re.findall(r'<script type="application/octet-stream" id="([a-z-]+)">([^<]*)</script>', page))
    assert gzip.decompress(base64.b64decode(blobs["viewer-gz"])).decode() == viewer
    scenes = json.loads(gzip.decompress(base64.b64decode(blobs["scenes-gz"])))
    assert [s["commands"] for s in scenes] == [["AAAA"], ["AAAA"]]
    assert page.count("/* three.js */") == 0 and page.count('class="cell"') == 2
    assert gallery_page([_scene()], viewer) == gallery_page([_scene()], viewer)      # no time stamp in the gzip


def test_the_gallery_refuses_to_exceed_the_data_uri_limit():
    import os
    noise = base64.b64encode(os.urandom(1_700_000)).decode()    # incompressible
    with pytest.raises(RoboballError, match="over the 2 MiB"):
        gallery_page([_scene(commands=[noise])], "var MeshCat = {};", source="x.html")
    assert data_uri_length(3 * 1024) < DATA_URI_LIMIT < data_uri_length(1_600_000)
