"""A shell whose pressure follows a schedule p(t).

Laws as in the pipeline's shell regression (Fig. 10 shape): zeta falls and omega_n rises with
pressure, so a softer shell injects more damping (C_inject = 2 M_eq omega_n zeta) and a ramp
descent at low pressure is slower.  A deflating shell must start like the high-pressure run and
end up near the low-pressure one, between the two all the way.
"""
import numpy as np
import pytest

from roboball.errors import RoboballError
from roboball.sim.plant import build
from roboball.sim.pressure import pressure_shell_system
from roboball.sim.scenarios import simulate
from roboball.sim.schedule import PressureSchedule, ShellLaws
from roboball.sim.schedule_run import hydro_properties, simulate_schedule
from roboball.sim.spec import ShellParams, SimSpec

LAWS = ShellLaws(zeta_a=0.2282, zeta_b=-0.03819, omega_n_c=2.702, omega_n_d=0.02761)
HI, LO = 20.7, 6.9
T = 2.5
FRICTION = {"steer": "majd", "drive": "majd"}


def ramp_spec(contact, geometry="planar"):
    # The paper's ramp model: injected damping about the driveshaft only (section IV).
    return SimSpec(kind="ramp", contact=contact, friction=FRICTION,
                   shell=ShellParams(injected_steer=False, injected_drive=True, geometry=geometry))


def constant_spec(contact, p, geometry="planar"):
    spec = ramp_spec(contact, geometry)
    spec.pressure_kpa = p
    spec.shell.zeta, spec.shell.omega_n = float(LAWS.zeta(p)), float(LAWS.omega_n(p))
    return spec


# ---- the schedule itself --------------------------------------------------------------------
def test_schedule_interpolates_holds_and_matches_drake_trajectory():
    s = PressureSchedule((0.5, 2.5), (HI, LO))
    assert s.at(0.0) == HI and s.at(10.0) == LO
    assert s.at(1.5) == pytest.approx((HI + LO) / 2)
    traj = s.trajectory()
    for t in (0.0, 0.5, 1.0, 2.2, 3.0):
        assert traj.value(t)[0, 0] == pytest.approx(float(s.at(t)), abs=1e-12)
    c = PressureSchedule.constant(13.8)
    assert c.is_constant and c.trajectory().value(7.0)[0, 0] == 13.8


def test_schedule_from_csv_and_config(tmp_path):
    f = tmp_path / "deflate.csv"
    f.write_text("time_s,pressure_kpa\n0,20.7\n3,6.9\n")
    s = PressureSchedule.from_csv(f)
    assert s.times_s == (0.0, 3.0) and s.pressures_kpa == (20.7, 6.9)
    assert PressureSchedule.from_config({"csv": str(f)}) == s
    assert PressureSchedule.from_config({"time_s": [0, 3], "pressure_kpa": [20.7, 6.9]}).at(1.5) == pytest.approx(13.8)
    lin = PressureSchedule.from_config({"start_kpa": 20.7, "end_kpa": 6.9, "t_start_s": 0, "t_end_s": 3})
    assert lin.at(1.5) == pytest.approx(13.8)
    assert PressureSchedule.from_config(13.8).at(99.0) == 13.8


@pytest.mark.parametrize("text,needle", [
    ("time_s,pressure_kpa\n0,20.7\n0,6.9\n", "row 2: time_s 0 does not increase"),
    ("time_s,pressure_kpa\n0,20.7\n1,-3\n", "row 2: pressure_kpa -3 outside"),
    ("time_s,pressure_kpa\n0,abc\n", "row 1:"),
    ("time,pressure_kpa\n0,20.7\n", "missing column 'time_s'"),
    ("time_s,pressure_kpa\n", "no rows"),
])
def test_bad_schedule_is_one_line_error_naming_file_and_row(tmp_path, text, needle):
    f = tmp_path / "bad.csv"
    f.write_text(text)
    with pytest.raises(RoboballError) as exc:
        PressureSchedule.from_csv(f)
    msg = str(exc.value)
    assert "\n" not in msg and str(f) in msg and needle in msg


# ---- the pressure-input system equals the constant-coefficient shell at every pressure --------
@pytest.mark.parametrize("geometry", ["planar", "3d"])
def test_pressure_port_gives_the_constant_models_force(robot, geometry):
    """Same state, pressure on the input port vs K, C computed beforehand (eq. 7-8)."""
    spec = SimSpec(kind="ramp", contact="point", shell=ShellParams(geometry=geometry))
    built = build(spec)
    lay = built.layout
    system = pressure_shell_system(lay, LAWS, robot, spec.shell, built.ground_normal)
    rng = np.random.default_rng(3)
    q = np.zeros(lay.nq)
    quat = rng.normal(size=4)
    q[lay.base_q:lay.base_q + 4] = quat / np.linalg.norm(quat)
    x = np.concatenate([q, rng.normal(size=lay.nv)])
    for p in (LO, 13.8, HI):
        ctx = system.CreateDefaultContext()
        system.GetInputPort("plant_state").FixValue(ctx, x)
        system.GetInputPort("pressure_kpa").FixValue(ctx, [p])
        tau_p = system.GetOutputPort("generalized_force").Eval(ctx)
        ref = build(SimSpec(kind="ramp", contact="injected", pressure_kpa=p,
                            shell=ShellParams(zeta=float(LAWS.zeta(p)), omega_n=float(LAWS.omega_n(p)),
                                              geometry=geometry)))
        rctx = ref.force_system.CreateDefaultContext()
        ref.force_system.get_input_port(0).FixValue(rctx, x)
        tau_c = ref.force_system.get_output_port(0).Eval(rctx)
        assert np.abs(tau_c).max() > 0.1
        np.testing.assert_allclose(tau_p, tau_c, rtol=1e-12, atol=1e-12)


# ---- acceptance 1: injected shell ------------------------------------------------------------
@pytest.fixture(scope="module")
def injected_runs():
    out = {name: simulate_schedule(ramp_spec("injected"), s, LAWS, 0.0, T, sample_rate_hz=100)
           for name, s in [("hi", PressureSchedule.constant(HI)), ("lo", PressureSchedule.constant(LO)),
                           ("deflating", PressureSchedule.linear(HI, LO, 0.0, T))]}
    out["hi_fixed"] = simulate(constant_spec("injected", HI), 0.0, T, sample_rate_hz=100)
    return out


def test_constant_schedule_reduces_to_the_constant_pressure_run(injected_runs):
    a = injected_runs["hi"].drive_rate_rad_s.to_numpy()
    b = injected_runs["hi_fixed"].drive_rate_rad_s.to_numpy()
    assert len(a) == len(b) and np.abs(b).max() > 2.0
    assert np.abs(a - b).max() < 1e-9


def test_deflating_run_lies_between_the_constant_runs(injected_runs):
    hi = injected_runs["hi"].drive_rate_rad_s.to_numpy()
    lo = injected_runs["lo"].drive_rate_rad_s.to_numpy()
    de = injected_runs["deflating"].drive_rate_rad_s.to_numpy()
    t = injected_runs["deflating"].time_s.to_numpy()
    assert injected_runs["deflating"].pressure_kpa.iloc[-1] == pytest.approx(LO)
    # Softer shell, more injected damping, slower: hi >= deflating >= lo at every sample.
    assert np.all(hi - de >= -1e-9) and np.all(de - lo >= -1e-9)
    end = t >= T - 0.3
    assert np.all(hi[end] - de[end] > 0.3)            # clearly slower than the stiff shell by the end
    early = (t > 0.2) & (t < 0.6)
    # At first it rolls like the 20.7 kPa shell, at the end much nearer the 6.9 kPa one.
    assert np.all(hi[early] - de[early] < 0.3 * (hi[early] - lo[early]))
    assert np.mean(de[end] - lo[end]) < 0.5 * np.mean(hi[end] - lo[end])


# ---- acceptance 1: hydroelastic (properties replaced between segments) -------------------------
def test_hydroelastic_schedule_constant_and_deflating(robot):
    spec = ramp_spec("hydroelastic")
    Th = 1.5
    hi = simulate_schedule(spec, PressureSchedule.constant(HI), LAWS, 0.0, Th).drive_rate_rad_s.to_numpy()
    lo = simulate_schedule(spec, PressureSchedule.constant(LO), LAWS, 0.0, Th).drive_rate_rad_s.to_numpy()
    de = simulate_schedule(spec, PressureSchedule.linear(HI, LO, 0.0, Th), LAWS, 0.0, Th,
                           hydro_update_s=0.05).drive_rate_rad_s.to_numpy()
    fixed = simulate(constant_spec("hydroelastic", HI), 0.0, Th).drive_rate_rad_s.to_numpy()
    assert np.abs(hi - fixed).max() < 1e-9
    m_hi, d_hi = hydro_properties(robot, spec.shell, LAWS, HI)
    m_lo, d_lo = hydro_properties(robot, spec.shell, LAWS, LO)
    assert m_lo < m_hi and d_lo > d_hi          # softer and more dissipative when deflated
    assert hi[-1] - de[-1] > 0.2 and de[-1] - lo[-1] > 0.05
    # Between the two once rolling (in the first 0.15 s the contact patches settle and the
    # softer shell briefly leads by < 0.005 rad/s).
    rolling = np.arange(len(de)) * 0.01 >= 0.3
    assert np.all(de[rolling] <= hi[rolling]) and np.all(de[rolling] >= lo[rolling])


def test_replacing_properties_in_context_equals_rebuilding_with_state_carried(robot):
    """What Drake allows: new proximity properties in the running context between AdvanceTo
    calls give the same trajectory as a diagram rebuilt with them and the state copied over."""
    from pydrake.systems.analysis import Simulator

    from roboball.sim.scenarios import set_release
    from roboball.sim.schedule_run import hydro_updater

    spec = SimSpec(kind="shell_rock", contact="hydroelastic", pressure_kpa=HI,
                   shell=ShellParams(zeta=float(LAWS.zeta(HI)), omega_n=float(LAWS.omega_n(HI))))
    switch = PressureSchedule((0.0, 0.7, 0.7 + 1e-9), (HI, HI, LO))     # a step at 0.7 s
    update = hydro_updater(switch, LAWS)
    b0 = build(spec)
    s0 = Simulator(b0.diagram)
    c0 = s0.get_mutable_context()
    set_release(b0, c0, 0.1)
    for t0, t1 in ((0.0, 0.7), (0.7, 1.4)):
        update(b0, c0, t0, t1)
        s0.AdvanceTo(t1)
    x_ctx = b0.plant.GetPositionsAndVelocities(b0.plant.GetMyContextFromRoot(c0))
    b1 = build(spec)
    s1 = Simulator(b1.diagram)
    set_release(b1, s1.get_mutable_context(), 0.1)
    s1.AdvanceTo(0.7)
    x_mid = b1.plant.GetPositionsAndVelocities(b1.plant.GetMyContextFromRoot(s1.get_context()))
    spec_lo = SimSpec(kind="shell_rock", contact="hydroelastic", pressure_kpa=LO,
                      shell=ShellParams(zeta=float(LAWS.zeta(LO)), omega_n=float(LAWS.omega_n(LO))))
    b2 = build(spec_lo)
    s2 = Simulator(b2.diagram)
    c2 = s2.get_mutable_context()
    c2.SetTime(0.7)
    b2.plant.SetPositionsAndVelocities(b2.plant.GetMyMutableContextFromRoot(c2), x_mid)
    s2.AdvanceTo(1.4)
    x_end = b2.plant.GetPositionsAndVelocities(b2.plant.GetMyContextFromRoot(c2))
    np.testing.assert_allclose(x_ctx, x_end, atol=1e-12)
    # ... and the switch mattered: the run that stayed at 20.7 kPa ends elsewhere.
    s1.AdvanceTo(1.4)
    x_stay = b1.plant.GetPositionsAndVelocities(b1.plant.GetMyContextFromRoot(s1.get_context()))
    assert np.abs(x_stay - x_end).max() > 1e-3


# ---- Fig. S1 stage -----------------------------------------------------------------------------
def _regression_csv(path):
    path.write_text("name,value\nzeta_a,0.2282\nzeta_b,-0.03819\nomega_n_c,2.702\nomega_n_d,0.02761\n")
    return str(path)


def test_fig_s1_stage_writes_figure_and_traces(tmp_path):
    import pandas as pd

    from roboball.pipeline.deflating import deflating_ramp

    reg = _regression_csv(tmp_path / "reg.csv")
    png = tmp_path / "figS1_deflating_ramp.png"
    deflating_ramp(regression=reg, out_png=str(png), out_csv=str(tmp_path / "tr.csv"), duration=1.0,
                   contacts=["injected"])
    assert png.stat().st_size > 10_000 and png.with_suffix(".pdf").stat().st_size > 5_000
    tr = pd.read_csv(tmp_path / "tr.csv")
    last = tr.groupby("case").drive_rate_rad_s.last()
    assert set(last.index) == {"constant 20.7 kPa", "constant 6.9 kPa", "schedule"}
    assert last["constant 20.7 kPa"] > last["schedule"] > last["constant 6.9 kPa"]
    assert tr[tr.case == "schedule"].pressure_kpa.iloc[-1] == pytest.approx(LO)


def test_fig_s1_stage_refuses_a_constant_schedule_and_missing_regression(tmp_path):
    from roboball.pipeline.deflating import deflating_ramp

    reg = _regression_csv(tmp_path / "reg.csv")
    with pytest.raises(RoboballError, match="constant"):
        deflating_ramp(regression=reg, out_png=str(tmp_path / "f.png"), schedule_time_s=["0"],
                       schedule_pressure_kpa=["13.8"])
    with pytest.raises(RoboballError, match="shell regression table not found"):
        deflating_ramp(regression=str(tmp_path / "none.csv"), out_png=str(tmp_path / "f.png"))
    assert not (tmp_path / "f.png").exists()


def test_plain_build_refuses_a_hydroelastic_schedule():
    """Hydroelastic properties are not inputs: a schedule must go through simulate_schedule."""
    spec = SimSpec(kind="ramp", contact="hydroelastic", pressure_kpa=HI,
                   pressure_schedule=PressureSchedule.linear(HI, LO, 0.0, 1.0), shell_laws=LAWS)
    with pytest.raises(ValueError, match="simulate_schedule"):
        build(spec)
