"""The compiled loops of the diagnosis's models (roboball.reduced.compiled) against their NumPy
loops: the same trajectories, batch rows with every effect mix, the effects scattered over the
batch as a search grows several models at once; and the ramp's equations, which both of its loops
share (roboball.reduced.ramp_equations), against the Lagrange equations they solve."""
import os
import subprocess
import sys

import numpy as np
import pytest

from roboball.pipeline.numerics import PINNED

from roboball.physics import effects as fx
from roboball.physics.mathns import NP
from roboball.reduced import ramp_equations as eq
from roboball.reduced.ramp import RampModel
from roboball.reduced.shell import ShellModel
from roboball.reduced.shell_steer import ShellSteerModel
from roboball.reduced.stand import StandModel


def _batch(model, B, rng):
    """B rows: each effect of the model on a random third of the rows, at a typical size."""
    P = {}
    for name in model.candidates:
        for p in fx.LIBRARY[name].params:
            key = f"{name}.{p.name}"
            if key in model.held_params:
                P[key] = np.full(B, model.held_params[key])
            elif p is fx.LIBRARY[name].params[0]:
                on = rng.random(B) < 0.35
                P[key] = np.where(on, p.typical * rng.uniform(0.3, 3.0, B), 0.0)
            else:
                P[key] = np.full(B, p.typical)
    for b in getattr(model, "base_params", ()):
        P[b.name] = rng.uniform(0.05, 0.5, B)
    return P


@pytest.mark.parametrize("name", ["StandModel", "ShellModel", "ShellSteerModel", "RampModel"])
def test_compiled_loop_gives_the_numpy_loops_trajectories(name):
    (Qn, Vn), (Qc, Vc) = _runs(name)
    assert Qc.shape == Qn.shape == (1501, 64) and Vc.shape == Vn.shape
    # equal to the last bits of sin, exp and tanh, which NumPy's SIMD code may round otherwise
    # (a dry-friction stop amplifies them, to well below a sensor's 1 mrad)
    assert np.max(np.abs(Qc - Qn)) < 1e-5
    assert np.median(np.abs(Qc - Qn)) < 1e-12


EXACT = """
import sys
sys.path.insert(0, {here!r})
import numpy as np
from test_compiled import _runs
for name in ("StandModel", "ShellModel", "ShellSteerModel", "RampModel"):
    (Qn, Vn), (Qc, Vc) = _runs(name)
    print(name, bool(np.array_equal(Qn, Qc) and np.array_equal(Vn, Vc)))
"""


def _runs(name):
    """The NumPy and the compiled loop's (Q, V) of a mixed batch of model `name`."""
    make = {"StandModel": StandModel, "ShellModel": ShellModel, "ShellSteerModel": ShellSteerModel,
            "RampModel": RampModel}[name]
    rng = np.random.default_rng(5)
    model = make()
    B, n = 64, 1500
    P = _batch(model, B, rng)
    q0 = model.rest + rng.uniform(-0.6, 0.6, B)
    if isinstance(model, ShellSteerModel):
        P["steer_angle"] = rng.uniform(-0.8, 0.8, B)
        P["steer_rate"] = rng.uniform(-3.0, 3.0, B)
    model.compiled = False
    numpy_loop = model.simulate(q0, P, n)
    model.compiled = True
    return numpy_loop, model.simulate(q0, P, n)


def test_under_the_pipelines_pinned_numerics_the_compiled_loops_are_bit_for_bit_the_numpy_loops():
    """With NumPy's transcendental functions libm's (the pipeline's pins, roboball.pipeline.numerics)
    both loops round every operation alike: a diagnosis gives the same numbers either way."""
    env = dict(os.environ, **PINNED)
    out = subprocess.run([sys.executable, "-c", EXACT.format(here=os.path.dirname(__file__))], env=env,
                         capture_output=True, text=True, check=True).stdout.split()
    assert out == ["StandModel", "True", "ShellModel", "True", "ShellSteerModel", "True", "RampModel", "True"], out


@pytest.mark.parametrize("make", [StandModel, ShellModel, ShellSteerModel])
def test_a_batch_run_a_stretch_at_a_time_with_rows_dropped_is_the_whole_run_to_the_bit(make):
    rng = np.random.default_rng(9)
    model = make()
    B = 24
    P = _batch(model, B, rng)
    q0 = model.rest + rng.uniform(-0.5, 0.5, B)
    if isinstance(model, ShellSteerModel):
        P["steer_angle"] = rng.uniform(-0.8, 0.8, B)
        P["steer_rate"] = rng.uniform(-3.0, 3.0, B)
    Q, V = model.simulate(q0, P, 900)
    st = model.stepper(q0, P)
    Q1, V1 = st.advance(400)
    keep = np.arange(0, B, 3)
    st.keep(keep)
    Q2, V2 = st.advance(500)
    assert np.array_equal(Q1, Q[:401]) and np.array_equal(V1, V[:401])
    assert np.array_equal(Q2, Q[400:, keep]) and np.array_equal(V2, V[400:, keep])


def test_an_edited_law_is_compiled_afresh_not_loaded_from_the_cache(tmp_path):
    """Numba stamps a cached kernel with its own file only; the kernels hold roboball.physics'
    laws compiled in, so an edited law must not load the old machine code (it once did: the
    kernel kept -c qd after viscous_damping became -2 c qd)."""
    import shutil
    import roboball
    package = tmp_path / "roboball"
    shutil.copytree(os.path.dirname(roboball.__file__), package,
                    ignore=shutil.ignore_patterns("__pycache__"))
    probe = ("from roboball.reduced import compiled\n"
             "print(repr(compiled._torque(0, 0.1, 1.0, 0.5, 0.0, 1.0)))\n")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = str(tmp_path)

    def torque():
        out = subprocess.run([sys.executable, "-c", probe], env=env, cwd=tmp_path,
                             capture_output=True, text=True, check=True)
        return float(out.stdout)

    assert torque() == -0.5
    effects = package / "physics" / "effects.py"
    text = effects.read_text()
    assert text.count("return -c * qd") == 1
    effects.write_text(text.replace("return -c * qd", "return -2.0 * c * qd"))
    assert torque() == -1.0
    assert len(list((package / "reduced" / "__pycache__").glob("roboball-kernels-*"))) == 2


def test_the_ramp_rows_start_sliding_at_their_own_steps_in_both_loops():
    """The ramp's contact switching, not only rolling: each row starts to slide at a step of its
    own (the more damping, the sooner), which the compiled loop decides row by row while NumPy
    re-evaluates the whole batch; both give the same rates."""
    model = RampModel()
    P = {"viscous_damping.c": np.array([0.0, 0.5, 8.0, 20.0])}
    seen = []
    switch = model._contact_mode

    def record(*args):
        out = switch(*args)
        seen.append(out[0].copy())
        return out
    model._contact_mode = record
    model.compiled = False
    Yn, Ydn = model.simulate(np.zeros(4), P, 1500)
    steps_sliding = np.array(seen).sum(axis=0)
    assert np.all(np.diff(steps_sliding) > 0) and steps_sliding[0] > 0 and steps_sliding[-1] < 1500
    model.compiled = True
    Yc, Ydc = model.simulate(np.zeros(4), P, 1500)
    assert np.max(np.abs(Yc - Yn)) < 1e-9 and np.max(np.abs(Ydc - Ydn)) < 1e-6


def test_the_ramp_equations_solve_the_lagrange_equations_of_rolling_and_sliding():
    """Accelerations from roboball.reduced.ramp_equations put back into the equations of motion of
    roboball.reduced.ramp's docstring leave no residual: rolling with the friction it reports as
    needed, sliding with mu N against the slip, and the normal force from the slope's normal
    balance.  Both loops take their physics from these functions, so an error there fails here."""
    model = RampModel()
    k = eq.constants(model)
    M, m_p, zc, R, a, g = model.m_s + model.m_p, model.m_p, model.z_c, model.radius, model.alpha, model.g
    I_s, I_b = model.i_s, model.i_p + m_p * zc ** 2
    rng = np.random.default_rng(3)
    n = 50
    be, wb, w = rng.uniform(-1.0, 1.0, n), rng.uniform(-4.0, 4.0, n), rng.uniform(-2.0, 15.0, n)
    tau_d, q_th = rng.uniform(-0.3, 0.3, n), rng.uniform(-0.5, 0.5, n)
    cba, sba, rhs_s, rhs_b = eq.terms(be, wb, tau_d, k, NP)
    s2, th2, be2, F, N = eq.rolling(cba, sba, rhs_s, rhs_b, wb, q_th, k)
    c, s = np.cos(be - a), np.sin(be - a)

    def residuals(s2, th2, be2, F):
        slope = M * s2 + m_p * zc * (c * be2 - s * wb ** 2) - M * g * np.sin(a) - F
        shell = I_s * th2 + R * F - q_th
        pend = I_b * be2 + m_p * zc * c * s2 - m_p * g * zc * np.sin(be) - tau_d
        return np.abs(np.concatenate([slope, shell, pend])).max()

    assert np.allclose(s2, R * th2, rtol=1e-14, atol=0.0)
    assert residuals(s2, th2, be2, F) < 1e-9
    # the normal force: the mass centre's acceleration normal to the slope, from the pendulum alone
    assert np.allclose(N, M * g * np.cos(a) + m_p * zc * (-s * be2 - c * wb ** 2), rtol=1e-12)
    direction = np.sign(rng.uniform(-1.0, 1.0, n))
    s2, th2, be2 = eq.sliding(cba, rhs_s, rhs_b, q_th, N, direction, k, NP)
    assert residuals(s2, th2, be2, model.mu * np.maximum(N, 0.0) * direction) < 1e-9
    # Coulomb's cone and the re-stick that conserves the shell's momentum about the contact
    assert np.array_equal(eq.exceeds_cone(F, N, k, NP), np.abs(F) > model.mu * np.maximum(N, 0.0))
    vs = rng.uniform(0.0, 2.0, n)
    vs1, w1 = eq.restick(vs, w, k)
    assert np.allclose(vs1, R * w1) and np.allclose(M * R * vs + I_s * w, M * R * vs1 + I_s * w1)
