"""The URDF is generated from the robot facts (configs/robot.yaml) and from nothing else:
Drake parses it into the masses, centres of mass and inertias of the facts, the shell's
contact tags are the facts' values, and `roboball urdf` writes it (or refuses bad facts)."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from roboball.config import ROBOT_YAML, load_robot
from roboball.sim.urdf import ShellTags, make_urdf

ROBOBALL = str(Path(sys.executable).parent / "roboball")


def _plant(text: str):
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    plant = MultibodyPlant(0.0)
    Parser(plant).AddModelsFromString(text, "urdf")
    plant.Finalize()
    return plant


def test_drake_reads_the_links_of_the_robot_facts():
    robot = load_robot()
    plant = _plant(make_urdf(robot))
    for name, link in robot.links.items():
        body = plant.GetBodyByName(name)
        m = body.default_spatial_inertia()
        assert m.get_mass() == pytest.approx(link.mass_kg, rel=1e-12)
        assert np.allclose(m.get_com(), link.com_m, atol=1e-12)
        about_com = m.Shift(m.get_com()).CalcRotationalInertia().CopyToFullMatrix3()
        assert np.allclose(np.diag(about_com), link.inertia_kg_m2, rtol=1e-9)
    for jname in robot.joints:
        assert plant.HasJointNamed(jname)


def test_the_shell_tags_come_from_the_robot_facts(tmp_path):
    """An exported URDF carries the facts' contact values; edit the facts and it follows."""
    data = yaml.safe_load(ROBOT_YAML.read_text())
    data["hydroelastic_defaults"]["modulus_pa"] = 2.5e6
    data["shell"]["ground_friction"] = 0.35
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(data))
    robot = load_robot(path)
    assert ShellTags.of(robot) == ShellTags(hydro_modulus=2.5e6, hunt_crossley=0.5, mu=0.35, resolution_hint=0.1)
    text = make_urdf(robot)
    assert '<drake:hydroelastic_modulus value="2500000.0"/>' in text
    assert '<drake:mu_dynamic value="0.35"/>' in text and '<drake:mu_static value="0.35"/>' in text


def test_cli_writes_the_urdf_and_refuses_bad_facts(tmp_path):
    out = tmp_path / "robot.urdf"
    r = subprocess.run([ROBOBALL, "urdf", "--out", str(out)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert out.read_text() == make_urdf(load_robot())

    data = yaml.safe_load(ROBOT_YAML.read_text())
    data["links"]["pendulum"]["mass_kg"] = -1.0
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(data))
    out2 = tmp_path / "bad.urdf"
    r = subprocess.run([ROBOBALL, "urdf", "--robot", str(bad), "--out", str(out2)],
                       capture_output=True, text=True, timeout=120)
    lines = [l for l in r.stderr.splitlines() if l.strip()]
    assert r.returncode != 0 and len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert "bad.yaml" in lines[0] and "links.pendulum.mass_kg" in lines[0]
    assert not out2.exists()
