"""The numbers a user reads from the robot facts and the generated URDF are the numbers of
shared/specs/robot-facts.md: masses and weight, Table I, the experiments, the derived constants
(eq. 4-5, the stands, the rest angles), and every joint, limit and geometry of the URDF, including
the drive stand's re-rooted tree.  Expected values are typed in from robot-facts.md or computed by
hand from its link table, never taken from roboball itself."""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from roboball.config import load_robot
from roboball.sim.urdf import make_urdf

ROBOT = load_robot()
DRAKE_NS = "{http://drake.mit.edu}"

# robot-facts.md, link table
M_PC, M_P, M_S = 2.77934, 22.03, 16.53649
R, G = 0.305, 9.81


# ---- config.py: facts and derived constants ----------------------------------------------
def test_total_mass_and_weight():
    assert ROBOT.total_mass == pytest.approx(41.34583, rel=1e-12)
    assert ROBOT.weight_n == pytest.approx(41.34583 * 9.81, rel=1e-12)      # 405.60 N


def test_table1_majd_parameters_per_joint():
    assert ROBOT.majd_params("steer") == pytest.approx({"f_w": 0.20, "f_c": 0.45, "sigma": 10.0, "omega_c": 0.1, "n": 1.0})
    assert ROBOT.majd_params("drive") == pytest.approx({"f_w": 1.78, "f_c": 1.24, "sigma": 8.33, "omega_c": 1.36, "n": 1.60})


def test_experiment_facts_keep_their_units():
    assert ROBOT.ramp_angle_deg == 16.0
    assert ROBOT.test_pressures_kpa == pytest.approx([6.9, 10.3, 13.8, 17.2, 20.7])
    assert ROBOT.radius == R and ROBOT.g == G


def test_locked_steer_shell_constants_of_robot_facts():
    # robot-facts.md: M_eq = 4.191 kg m^2, K_eq = 21.89 N m/rad, omega_n = 2.286 rad/s (0.364 Hz)
    # (roboball adds the pendulum's lateral CoM offset to its parallel-axis term: 4.19157; the
    # paper's eq. 4 with r_p = CoM depth gives 4.19132; both are 4.191 to the facts' precision)
    assert ROBOT.M_eq == pytest.approx(4.191, abs=1e-3)
    assert ROBOT.K_eq == pytest.approx(21.89, abs=5e-3)
    assert ROBOT.K_eq == pytest.approx((M_PC * 0.05 + M_P * 0.095) * G, rel=1e-12)
    assert ROBOT.omega_n_eq5 == pytest.approx(2.286, abs=1e-3)
    assert ROBOT.omega_n_eq5 / (2 * math.pi) == pytest.approx(0.364, abs=5e-4)
    # -atan(22.03 * 0.0033714 / (22.03 * 0.095 + 2.77934 * 0.05))
    assert ROBOT.shell_rest_angle == pytest.approx(-math.atan(M_P * 0.0033714 / (M_P * 0.095 + M_PC * 0.05)), abs=1e-12)
    assert ROBOT.shell_rest_angle == pytest.approx(-0.0333, abs=5e-5)


def test_steer_stand_constants_of_robot_facts():
    t = ROBOT.steer_stand_terms
    # robot-facts.md: I = 0.6414 kg m^2, m g d = 20.54 N m, omega = 5.659 rad/s, rest -0.0355 rad
    d2 = 0.0033714 ** 2 + 0.095 ** 2
    assert t["inertia"] == pytest.approx(0.44235 + M_P * d2, rel=1e-12)
    assert t["inertia"] == pytest.approx(0.6414, abs=1e-4)
    assert t["mgd"] == pytest.approx(M_P * G * math.sqrt(d2), rel=1e-12)
    assert t["mgd"] == pytest.approx(20.54, abs=5e-3)
    assert t["omega_n"] == pytest.approx(5.659, abs=1e-3)
    assert t["rest_angle"] == pytest.approx(-math.atan(0.0033714 / 0.095), abs=1e-12)
    assert t["rest_angle"] == pytest.approx(-0.0355, abs=5e-5)


def test_drive_stand_constants_by_hand():
    """pitch_center + pendulum about the drive (y) axis: Iyy + m (x^2 + z^2) of each link."""
    t = ROBOT.drive_stand_terms
    inertia = (0.00754 + M_PC * 0.05 ** 2) + (0.49888 + M_P * 0.095 ** 2)     # 0.71219 kg m^2
    mgd = (M_PC * 0.05 + M_P * 0.095) * G                                      # 21.894 N m
    assert t["inertia"] == pytest.approx(inertia, rel=1e-12)
    assert t["mgd"] == pytest.approx(mgd, rel=1e-12)
    assert t["omega_n"] == pytest.approx(math.sqrt(mgd / inertia), rel=1e-12)  # 5.5445 rad/s
    assert t["rest_angle"] == 0.0


# ---- urdf.py: joints, limits, geometry -----------------------------------------------------
def _floats(text: str) -> list:
    return [float(x) for x in text.split()]


def _parsed(root: str = "pitch_center", fixed_joints=()):
    """(joints by name, XML tree) of a generated URDF."""
    tree = ET.fromstring(make_urdf(ROBOT, fixed_joints=fixed_joints, root=root))
    return {j.get("name"): j for j in tree.findall("joint")}, tree


def test_urdf_joints_are_those_of_robot_facts():
    joints, _ = _parsed()
    assert set(joints) == {"steer", "drive", "bedliner_weld"}
    steer, drive, weld = joints["steer"], joints["drive"], joints["bedliner_weld"]
    assert steer.get("type") == "revolute"
    assert (steer.find("parent").get("link"), steer.find("child").get("link")) == ("pitch_center", "pendulum")
    assert _floats(steer.find("axis").get("xyz")) == [1.0, 0.0, 0.0]
    lim = steer.find("limit")
    assert (float(lim.get("lower")), float(lim.get("upper"))) == (-1.57, 1.0)
    assert drive.get("type") == "continuous" and drive.find("limit") is None
    assert (drive.find("parent").get("link"), drive.find("child").get("link")) == ("pitch_center", "pipe_assembly")
    assert _floats(drive.find("axis").get("xyz")) == [0.0, -1.0, 0.0]
    assert weld.get("type") == "fixed"
    assert (weld.find("parent").get("link"), weld.find("child").get("link")) == ("pipe_assembly", "bedliner")
    # every joint origin is the pitch_center origin (the sphere's centre)
    for j in joints.values():
        assert _floats(j.find("origin").get("xyz")) == [0.0, 0.0, 0.0]
        assert _floats(j.find("origin").get("rpy")) == [0.0, 0.0, 0.0]


def test_urdf_fixing_one_joint_leaves_the_other_free():
    joints, _ = _parsed(fixed_joints=("steer",))
    assert joints["steer"].get("type") == "fixed" and joints["steer"].find("axis") is None
    assert joints["drive"].get("type") == "continuous"
    joints, _ = _parsed(root="pipe_assembly", fixed_joints=("drive",))
    assert joints["drive"].get("type") == "fixed" and joints["steer"].get("type") == "revolute"


def test_urdf_drive_stand_tree_is_rerooted_at_the_pipe_with_the_axis_negated():
    joints, _ = _parsed(root="pipe_assembly")
    drive = joints["drive"]
    assert (drive.find("parent").get("link"), drive.find("child").get("link")) == ("pipe_assembly", "pitch_center")
    assert _floats(drive.find("axis").get("xyz")) == [0.0, 1.0, 0.0]
    steer = joints["steer"]     # the steer joint is untouched
    assert (steer.find("parent").get("link"), steer.find("child").get("link")) == ("pitch_center", "pendulum")
    assert _floats(steer.find("axis").get("xyz")) == [1.0, 0.0, 0.0]


@pytest.mark.parametrize("root", ["pitch_center", "pipe_assembly"])
def test_drive_angle_means_the_same_pose_in_either_tree(root):
    """At drive angle q the pipe is turned by q about the drive axis (0, -1, 0) relative to
    pitch_center, whichever link roots the tree."""
    from pydrake.math import RotationMatrix
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    plant = MultibodyPlant(0.0)
    Parser(plant).AddModelsFromString(make_urdf(ROBOT, root=root), "urdf")
    plant.Finalize()
    ctx = plant.CreateDefaultContext()
    q = 0.4
    plant.GetJointByName("drive").set_angle(ctx, q)
    X = plant.CalcRelativeTransform(ctx, plant.GetFrameByName("pitch_center"), plant.GetFrameByName("pipe_assembly"))
    expected = RotationMatrix.MakeYRotation(-q).matrix()         # rotation by q about -y
    assert np.allclose(X.rotation().matrix(), expected, atol=1e-12)
    assert np.allclose(X.translation(), 0.0, atol=1e-12)


def test_urdf_shell_is_the_only_contact_geometry_with_the_facts_tags():
    _, tree = _parsed()
    with_collision = [l.get("name") for l in tree.findall("link") if l.find("collision") is not None]
    assert with_collision == ["bedliner"]
    bedliner = tree.find("link[@name='bedliner']")
    assert bedliner.find("inertial") is None                           # massless
    col = bedliner.find("collision")
    assert float(col.find("geometry/sphere").get("radius")) == 0.305
    props = col.find(f"{DRAKE_NS}proximity_properties")
    values = {c.tag[len(DRAKE_NS):]: c.get("value") for c in props}
    assert "compliant_hydroelastic" in values
    assert float(values["hydroelastic_modulus"]) == 1.8e6                 # Pa
    assert float(values["hunt_crossley_dissipation"]) == 0.5              # s/m
    assert float(values["mesh_resolution_hint"]) == 0.1                   # m
    assert float(values["mu_dynamic"]) == float(values["mu_static"]) == 0.2


def test_urdf_inertials_are_those_of_robot_facts():
    _, tree = _parsed()
    facts = {  # mass, com, (Ixx, Iyy, Izz) from robot-facts.md
        "pitch_center": (2.77934, [0.0, 0.0, -0.05], [0.01841, 0.00754, 0.01442]),
        "pendulum": (22.03, [0.0, 0.0033714, -0.095], [0.44235, 0.49888, 0.32633]),
        "pipe_assembly": (16.53649, [0.0, 0.0, 0.0], [1.04, 0.64074, 1.04]),
    }
    for name, (mass, com, diag) in facts.items():
        inertial = tree.find(f"link[@name='{name}']/inertial")
        assert float(inertial.find("mass").get("value")) == mass
        assert _floats(inertial.find("origin").get("xyz")) == com
        assert _floats(inertial.find("origin").get("rpy")) == [0.0, 0.0, 0.0]
        i = inertial.find("inertia").attrib
        assert [float(i["ixx"]), float(i["iyy"]), float(i["izz"])] == diag
        assert float(i["ixy"]) == float(i["ixz"]) == float(i["iyz"]) == 0.0
