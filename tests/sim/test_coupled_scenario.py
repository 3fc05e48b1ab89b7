"""The coupled steer scenario (issue 27): the drive held, the pendulum free on its steer joint, the
shell rocking on flat ground; the model list; the coarser step's equivalence."""
import numpy as np
import pytest

from roboball.sim.coupled import AUTHORS_HAND, AUTHORS_NM, DT_S, MODEL_NAMES, coupled_spec, model_spec, predict
from roboball.sim.plant import build
from roboball.sim.schedule import ShellLaws
from roboball.sim.spec import ShellParams

# the pipeline's shell regression as of the last pipeline run (any plausible law does here)
LAWS = ShellLaws(0.23, -0.0386, 2.70, 0.0276)
FRICTION = {"f_w": 0.2, "f_c": 0.45, "sigma": 10.0, "omega_c": 0.1, "n": 1.0}


def test_every_shell_model_is_listed_once_with_the_authors_pairs():
    assert MODEL_NAMES == ("point", "injected", "hydroelastic", "hydro_half", "authors_nm", "authors_hand")
    assert AUTHORS_NM == (1.55201e5, 0.405) and AUTHORS_HAND == (1.2e5, 0.75)
    nm = model_spec("authors_nm", None, LAWS, FRICTION)
    assert (nm.contact, nm.shell.hydro_modulus, nm.shell.hydro_dissipation) == ("hydroelastic", 1.55201e5, 0.405)
    tuned = model_spec("hydro_half", 20.0, LAWS, FRICTION)
    assert tuned.shell.dissipation_scale == 0.5 and tuned.pressure_kpa == 20.0
    with pytest.raises(ValueError, match="^coupled shell model 'injected' needs the pressure$"):
        model_spec("injected", None, LAWS, FRICTION)
    with pytest.raises(ValueError, match="^unknown coupled shell model 'lumpy'"):
        model_spec("lumpy", 20.0, LAWS, FRICTION)


def test_the_scenario_frees_the_steer_joint_holds_the_drive_and_floats_the_base():
    built = build(coupled_spec("point", ShellParams(), FRICTION, dt=DT_S))
    plant = built.plant
    assert plant.GetJointByName("steer").num_velocities() == 1
    assert not plant.HasJointNamed("drive") or plant.GetJointByName("drive").num_velocities() == 0
    assert plant.GetBodyByName("pitch_center").is_floating_base_body()


def test_the_stand_fits_rotor_inertia_goes_on_the_steer_joint():
    spec = coupled_spec("point", ShellParams(), {**FRICTION, "delta_i": 0.05})
    assert spec.added_inertia == {"steer": 0.05} and "delta_i" not in spec.friction_params["steer"]


def test_the_injected_shell_rolls_the_tilted_robot_back_and_the_rigid_sphere_does_not():
    """Released at phi = -0.37 rad with the pendulum hanging (theta = +0.39 rad), the robot's centre
    of mass is nearly over the contact: a rigid sphere barely moves in 1.5 s, the injected shell's
    stiffness K_inject (eq. 7) swings the pipe past zero, and the pendulum stays near hanging."""
    t = np.linspace(0.0, 1.5, 76)
    point = predict(model_spec("point", None, LAWS, FRICTION), t, -0.37, 0.39)
    injected = predict(model_spec("injected", 23.5, LAWS, FRICTION), t, -0.37, 0.39)
    assert abs(point["pipe_angle_rad"][-1] + 0.37) < 0.15
    assert injected["pipe_angle_rad"].max() > 0.1
    world = injected["pipe_angle_rad"] + injected["steer_angle_rad"]     # the pendulum against gravity
    assert np.max(np.abs(world)) < 0.3


@pytest.mark.parametrize("name", ["injected", "authors_nm"])
def test_the_2_ms_step_matches_1_ms_within_1_5_mrad(name):
    """DT_S = 2 ms is used because it moves no model by more than 1.5 mrad over 5 s (measured
    1.36 mrad at most, authors_nm; docs/coupled.md)."""
    t = np.linspace(0.0, 5.0, 251)
    a = predict(model_spec(name, 23.5, LAWS, FRICTION, dt=1e-3), t, -0.37, 0.39)
    b = predict(model_spec(name, 23.5, LAWS, FRICTION, dt=DT_S), t, -0.37, 0.39)
    assert max(np.max(np.abs(a[c] - b[c])) for c in a) < 1.5e-3


def test_a_log_that_starts_after_the_let_go_starts_the_run_moving_and_rolling_without_slip():
    from pydrake.systems.analysis import Simulator
    from roboball.sim.scenarios import set_release, set_release_rates

    built = build(model_spec("injected", 20.0, LAWS, FRICTION))
    sim = Simulator(built.diagram)
    ctx = sim.get_mutable_context()
    set_release(built, ctx, -0.36, 0.38)
    set_release_rates(built, ctx, pipe_rate=0.3, steer_rate=-0.02)
    plant, pctx = built.plant, built.plant.GetMyContextFromRoot(ctx)
    body = plant.GetBodyByName("pitch_center")
    V = plant.EvalBodySpatialVelocityInWorld(pctx, body)
    height = plant.GetFreeBodyPose(pctx, body).translation()[2]
    assert V.rotational()[0] == pytest.approx(0.3) and V.translational()[1] == pytest.approx(-0.3 * height)
    assert plant.GetJointByName("steer").get_angular_rate(pctx) == pytest.approx(-0.02)
    t = np.linspace(0.0, 0.04, 21)
    moving = predict(model_spec("injected", 20.0, LAWS, FRICTION), t, -0.36, 0.38,
                     rates0={"pipe_rate": 0.3, "steer_rate": 0.0})
    at_rest = predict(model_spec("injected", 20.0, LAWS, FRICTION), t, -0.36, 0.38)
    slope = np.polyfit(t, moving["pipe_angle_rad"] - at_rest["pipe_angle_rad"], 1)[0]
    assert slope == pytest.approx(0.3, rel=0.15)
