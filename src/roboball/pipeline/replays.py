"""Replay stages: one Meshcat replay per experiment kind (its scene and its page), the viewer
code they share, and the gallery of all of them for the Snakemake report.

These stages live apart from roboball.pipeline.simulation so that the replays' pages and scenery
can change without changing the fingerprint, and so the results, of every simulation.
"""
from __future__ import annotations

import json
from pathlib import Path

from roboball.atomic import write_text_atomic

# Declared before roboball.pipeline.simulation in the stage table, whose older `replay` (one
# self-contained page per replay) these replace.
STAGES = ("replay", "replay_viewer", "replay_gallery")


def replay(kind: str, contact: str, out_html: str, out_scene: str, regression: str = "", pressure_kpa: float = 13.8,
           release: float = 0.3, duration: float = 4.0, dissipation_scale: float = 1.0,
           ramp_length_m: float = 2.0) -> None:
    """A Drake Meshcat replay of one simulated run (Majd friction, Table I, on both joints): the
    scene as JSON (for the gallery) and a page that loads the shared meshcat.js beside it."""
    from roboball.config import load_robot
    from roboball.pipeline.simulation import shell_at
    from roboball.report.replays import standalone_page
    from roboball.sim.replay import record
    from roboball.sim.spec import ShellParams, SimSpec

    shell = ShellParams(dissipation_scale=dissipation_scale, injected_steer=kind != "ramp")
    if regression:
        shell.zeta, shell.omega_n = shell_at(regression, pressure_kpa)
    spec = SimSpec(kind=kind, contact=contact, friction={"steer": "majd", "drive": "majd"},
                   pressure_kpa=pressure_kpa, shell=shell)
    scene = record(spec, release, duration, ramp_length_m=ramp_length_m)
    facts = {"kind": kind, "contact": contact, "pressure_kpa": pressure_kpa, "release_rad": release,
             "duration_s": duration, "dissipation_scale": dissipation_scale,
             "friction": "Majd law on steer and drive joints, Table I values",
             "zeta": shell.zeta, "omega_n_rad_s": shell.omega_n,
             "ramp_angle_deg": load_robot().ramp_angle_deg, "ramp_length_m": ramp_length_m, **scene.facts}
    data = {"facts": facts, "commands": scene.commands, "camera_m": scene.camera_m, "target_m": scene.target_m,
            "follow": scene.follow}
    write_text_atomic(out_scene, json.dumps(data))
    write_text_atomic(out_html, standalone_page(data))


def replay_viewer(out_js: str) -> None:
    """Meshcat's viewer code, once, for every replay page in its folder."""
    from roboball.sim.replay import viewer_js

    write_text_atomic(out_js, viewer_js())


def replay_gallery(scenes: list, viewer: str, out_html: str) -> None:
    """Every replay in one self-contained page (the Snakemake report's replay result)."""
    from roboball.report.replays import gallery_page

    data = []
    for path in scenes:
        with open(path, encoding="utf-8") as fh:
            data.append(json.loads(fh.read()))
    write_text_atomic(out_html, gallery_page(data, Path(viewer).read_text(encoding="utf-8"), source=out_html))
