"""The 3-D injected shell.

It must equal the paper's planar injected model on locked-steer rocking (zeta and omega_n within
2%, extracted with the project's decay code), and give the same run in any heading: the whole
scene turned by 90 deg about the vertical (ramp included) must roll the same way, turned.
"""
import math

import numpy as np
import pytest
from pydrake.math import RollPitchYaw, RotationMatrix

from roboball.identify.shell.decay import extract_decay
from roboball.ingest.releases.record import Release
from roboball.sim.forces import Kin
from roboball.sim.plant import build
from roboball.sim.scenarios import simulate
from roboball.sim.shell3d import base_tilt
from roboball.sim.spec import ShellParams, SimSpec

# zeta, omega_n of the Fig. 10 regressions at 6.9 and 20.7 kPa
CASES = [(6.9, 0.1755, 2.893), (20.7, 0.1036, 3.274)]


def _decay(df, omega):
    t, y = df.time_s.to_numpy(), df.pipe_angle_rad.to_numpy()
    rel = Release(t_release_s=0.0, t_end_s=float(t[-1]), i_release=0, i_end=len(t) - 1, y_release=float(y[0]),
                  y_rest=float(np.mean(y[-100:])), held_from_s=0.0, half_period_s=math.pi / omega, noise=2e-4,
                  kind="shell_rock")
    return extract_decay(t, y, rel, noise=2e-4)


def _rock(geometry, zeta, omega, heading=0.0, p=13.8):
    spec = SimSpec(kind="shell_rock", contact="injected", pressure_kpa=p, heading_deg=heading,
                   shell=ShellParams(zeta=zeta, omega_n=omega, geometry=geometry))
    return simulate(spec, 0.08, 8.0, sample_rate_hz=100)


def test_tilt_is_the_roll_pitch_angle_and_ignores_yaw():
    built = build(SimSpec(kind="shell_rock"))
    lay = built.layout
    q = np.zeros(lay.nq)
    v = np.zeros(lay.nv)

    def tilt(rpy):
        q[lay.base_q:lay.base_q + 4] = RotationMatrix(RollPitchYaw(rpy)).ToQuaternion().wxyz()
        return np.array(base_tilt(Kin(lay, q, v, None)), float)

    np.testing.assert_allclose(tilt([0.3, 0, 0]), [0.3, 0, 0], atol=1e-12)      # planar pipe angle
    np.testing.assert_allclose(tilt([0, -0.2, 0]), [0, -0.2, 0], atol=1e-12)
    np.testing.assert_allclose(tilt([0, 0, 1.1]), [0, 0, 0], atol=1e-12)         # pure yaw: upright
    # Turning the body about world z turns its tilt with it (heading-equivariant).
    a = tilt([0.25, 0.1, 0.0])
    Rz = RotationMatrix.MakeZRotation(0.7)
    q[lay.base_q:lay.base_q + 4] = (Rz @ RotationMatrix(RollPitchYaw([0.25, 0.1, 0.0]))).ToQuaternion().wxyz()
    b = np.array(base_tilt(Kin(lay, q, v, None)), float)
    np.testing.assert_allclose(b, Rz.multiply(a), atol=1e-12)
    assert np.linalg.norm(a) == pytest.approx(math.acos(math.cos(0.25) * math.cos(0.1)), rel=1e-12)


@pytest.mark.parametrize("p,zeta,omega", CASES)
def test_3d_equals_planar_on_locked_steer_rocking(p, zeta, omega):
    planar = _decay(_rock("planar", zeta, omega, p=p), omega)
    full = _decay(_rock("3d", zeta, omega, p=p), omega)
    print(f"{p} kPa: planar zeta {planar.zeta:.5f} omega_n {planar.omega_n:.5f}; "
          f"3-D zeta {full.zeta:.5f} omega_n {full.omega_n:.5f}")
    assert planar.zeta == pytest.approx(zeta, rel=0.05)          # both reproduce the injected values
    assert full.zeta == pytest.approx(planar.zeta, rel=0.02)
    assert full.omega_n == pytest.approx(planar.omega_n, rel=0.02)


def test_rocking_in_any_heading():
    p, zeta, omega = CASES[0]
    ref = _rock("3d", zeta, omega)
    turned = _rock("3d", zeta, omega, heading=90.0)
    # pipe_angle is the base's roll in its own (yawed) frame: the same signal in any heading.
    assert np.abs(turned.pipe_angle_rad.to_numpy() - ref.pipe_angle_rad.to_numpy()).max() < 1e-9
    # The planar model is tied to world x: turned by 90 deg its stiffness and damping act on the
    # wrong axis and the rocking changes completely (this is what the 3-D model fixes).
    planar = _decay(_rock("planar", zeta, omega, heading=90.0), omega)
    assert planar.zeta < 0.5 * zeta


@pytest.mark.parametrize("heading", [90.0, -37.0])
def test_ramp_descent_in_any_heading(heading):
    """The ramp and the robot's release pose turned together about world z."""
    spec = dict(kind="ramp", contact="injected", friction={"steer": "majd", "drive": "majd"}, pressure_kpa=13.8,
                shell=ShellParams(zeta=0.135, omega_n=3.08, geometry="3d"))
    ref, x0 = simulate(SimSpec(**spec), 0.05, 1.5, return_states=True)
    turned, x1 = simulate(SimSpec(heading_deg=heading, **spec), 0.05, 1.5, return_states=True)
    w0, w1 = ref.drive_rate_rad_s.to_numpy(), turned.drive_rate_rad_s.to_numpy()
    assert w0.max() > 2.5                                         # it does roll down
    # Drake's own contact solution is rotation-invariant only to round-off and solver
    # tolerance: the bare point-contact robot turned by 90 deg differs by 4e-5 of its speed.
    # The 3-D shell stays at that level (measured <= 2e-4); the planar model is off by 3-10%.
    assert np.abs(w1 - w0).max() < 1e-3 * np.abs(w0).max()
    built = build(SimSpec(**spec))
    i = built.layout.base_q + 4
    Rz = RotationMatrix.MakeZRotation(math.radians(heading))
    np.testing.assert_allclose(x1[i:i + 3, -1], Rz.multiply(x0[i:i + 3, -1]), atol=2e-3)
    assert np.linalg.norm(x0[i:i + 2, -1]) > 0.3                   # travelled down the slope
    planar = dict(spec, shell=ShellParams(zeta=0.135, omega_n=3.08))
    wp0 = simulate(SimSpec(**planar), 0.05, 1.5).drive_rate_rad_s.to_numpy()
    wp1 = simulate(SimSpec(heading_deg=heading, **planar), 0.05, 1.5).drive_rate_rad_s.to_numpy()
    print(f"heading {heading:g}: 3-D max |dw| {np.abs(w1 - w0).max():.2e}, planar {np.abs(wp1 - wp0).max():.2e} rad/s")
    assert np.abs(wp1 - wp0).max() > 20 * np.abs(w1 - w0).max()   # the planar model is not


def test_3d_on_the_ramp_vs_the_planar_model():
    """On the ramp the 3-D damping is the planar model's steer + drive damping written for any
    direction: without its stiffness the two descents agree.  The 3-D stiffness then adds what
    the paper drops in the drive direction (K on the pendulum's forward swing): a bounded change."""
    from roboball.sim.plant import ground_normal
    from roboball.sim.shell import shell_coefficients
    from roboball.sim.shell3d import InjectedShell3D

    base = dict(kind="ramp", friction={"steer": "majd", "drive": "majd"}, pressure_kpa=13.8)
    shell = ShellParams(zeta=0.135, omega_n=3.08)
    planar = simulate(SimSpec(contact="injected", shell=shell, **base), 0.05, 2.5)
    full = simulate(SimSpec(contact="injected", shell=ShellParams(zeta=0.135, omega_n=3.08, geometry="3d"),
                            **base), 0.05, 2.5)
    k, c = shell_coefficients(build(SimSpec(**base)).robot, SimSpec(shell=shell, **base))
    damping_only = InjectedShell3D(k, c, normal=tuple(ground_normal(math.radians(16.0))), stiffness=False)
    c_only = simulate(SimSpec(contact="point", extra_terms=[damping_only], **base), 0.05, 2.5)
    wp, wf, wc = (df.drive_rate_rad_s.to_numpy() for df in (planar, full, c_only))
    moving = wp > 1.0
    rel_c = np.abs(wc - wp)[moving] / wp[moving]
    rel_k = np.abs(wf - wc)[moving] / wc[moving]
    print(f"3-D damping vs planar: max {rel_c.max():.4f}, mean {rel_c.mean():.4f}; "
          f"3-D stiffness effect: max {rel_k.max():.4f}, mean {rel_k.mean():.4f}")
    assert rel_c.max() < 0.03
    assert 0.005 < rel_k.mean() < 0.15
