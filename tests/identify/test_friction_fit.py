"""Friction identification (roboball.identify.friction): known parameters are recovered from
simulated stand swings, on the calibrated stand (added inertia, rest offset, release instants),
chains resume from HDF5, model comparison prefers the true law and never recommends an
unconverged chain, convergence is reported honestly, and on the real steer log every law's
posterior converges and the best tracks the swings within 50 mrad.

The fits on simulated swings are kept small (short swings, few walkers, a low autocorrelation
multiple) so they run in about a minute; the library's default multiple is 50.  The real-log
fits run with the pipeline's settings (about two and a half minutes on 2 cores)."""
import inspect
import json

import h5py
import numpy as np
import pytest

from roboball.reduced import planar as R
from roboball.config import CONFIG_DIR, load_robot, load_yaml
from roboball.errors import ConfigError, RoboballError
from roboball.identify.friction.comparison import comparison, recommendation
from roboball.identify.friction.fit import fit, fit_segments
from roboball.identify.friction.lsq import least_squares_fit
from roboball.identify.friction.moves import BoxedT, IndependentT
from roboball.identify.friction.priors import Prior, law_fixed, law_priors, stand_priors
from roboball.identify.friction.problem import RELEASE_HALF_WIDTH_RAD, FrictionProblem
from roboball.identify.friction.results import STAND_PARAMS
from roboball.identify.friction.sampler import sample_posterior
from roboball.identify.friction.segments import segments_from_arrays
from roboball.identify.friction.summary import WEAK_IDENTIFIABILITY, summarize
from roboball.physics import friction

from conftest import REAL_DATA

ROBOT = load_robot()
MAJD_TRUE = {"f_w": 0.2, "f_c": 0.45, "sigma": 3.0, "omega_c": 0.3, "n": 1.6}     # n: the priors' point value


def synthetic_stand(law, true, seed, angles=(0.9, -1.0, 0.7), duration=3.5, noise=1e-3, quantum=1e-3,
                    kind="steer_stand", added_inertia=0.0, rest_offset=0.0, shifts=None):
    """Three releases simulated finely (0.5 ms) at `true`, sampled irregularly (60-125 Hz with
    gaps), Gaussian noise and quantisation added; the release angle handed to the fit is off by
    a few mrad (as a release finder would give it).  The stand may be calibrated (its added
    inertia and rest offset) and each let-go `shifts` seconds after the instant handed to the fit."""
    rng = np.random.default_rng(seed)
    segs, t0 = [], 2.0
    for i, a in enumerate(angles):
        t = t0 + np.concatenate([[0.0], np.cumsum(rng.uniform(0.008, 0.016, int(duration * 130)))])
        t = t[t < t0 + duration]
        t = np.sort(np.concatenate([t, t[rng.choice(t.size, 3)]]))       # exact duplicate stamps
        let_go = t0 + (shifts[i] if shifts is not None else 0.0)
        y = R.simulate_stand(kind, t, a, 0.0, law, {k: np.array([v]) for k, v in true.items()}, t0=let_go, dt=5e-4,
                             added_inertia=added_inertia, rest_offset=rest_offset)[0]
        y = np.round((y + rng.normal(0.0, noise, y.size)) / quantum) * quantum
        segs.append((t, y, {"t_release_s": t0, "t_end_s": t0 + duration, "y_release": a + rng.normal(0, 0.003)}))
        t0 += duration + 4.0
    return segs


def test_library_defaults_are_the_strict_ones():
    sig = inspect.signature(fit_segments)
    assert sig.parameters["autocorr_multiple"].default == 50
    assert inspect.signature(fit).parameters["autocorr_multiple"].default == 50
    assert inspect.signature(sample_posterior).parameters["autocorr_multiple"].default == 50


@pytest.fixture(scope="module")
def majd_fit(tmp_path_factory):
    """One Majd fit on three simulated steer-stand releases, shared by the tests that read it."""
    segs = synthetic_stand("majd", MAJD_TRUE, seed=11)
    return fit_segments("steer_stand", "majd", segs, tmp_path_factory.mktemp("majd") / "majd.h5", None, seed=5,
                          walkers=32, autocorr_multiple=8, max_steps=1500, chunk=50, min_steps=50)


def test_majd_parameters_are_recovered_with_covering_intervals(majd_fit):
    res, samples = majd_fit
    assert res["fixed"]["n"] == MAJD_TRUE["n"]          # held by the priors' point value
    for name, truth in MAJD_TRUE.items():
        if name == "n":
            continue
        p = res["parameters"][name]
        # within 3 posterior sd of the median (sd from the 95% interval): four parameters
        # each inside their own 95% interval fail together one time in five by chance
        sd = (p["ci95_high"] - p["ci95_low"]) / 3.92
        assert abs(p["median"] - truth) < 3 * sd, (name, p, res["notes"])
        assert p["unit"] == friction.UNITS[name]
    # the well-determined ones are tight
    for name in ("f_w", "f_c"):
        p = res["parameters"][name]
        assert (p["ci95_high"] - p["ci95_low"]) / MAJD_TRUE[name] < 0.1
    noise = res["parameters"]["noise_rad"]
    assert noise["ci95_low"] < np.sqrt(1e-6 + 1e-6 / 12) < noise["ci95_high"] * 1.05
    conv = res["convergence"]
    assert conv["converged"], res["notes"]
    assert conv["chain_over_tau"] >= 8 and conv["steps"] - conv["burn_in"] >= 8 * conv["max_tau"]
    assert 0.05 < conv["acceptance_fraction"] < 0.9 and conv["ess_min"] > 0
    assert set(samples.columns) == {*MAJD_TRUE, "h_peak", "v_peak", *STAND_PARAMS, "noise_rad"} - {"n"} and len(samples) > 100
    angles = [a["median"] for a in res["release_angles"]]
    assert len(angles) == 3
    assert np.allclose(angles, [0.9, -1.0, 0.7], atol=3e-3)
    assert res["integration"]["parameter_shift_sd"] <= 0.2 and res["integration"]["step_error_rad"] < 0.2 * noise["median"]
    json.dumps(res)                                               # JSON-serialisable as it is


def test_reported_intervals_are_the_95_percent_ones_of_the_chain_after_burn_in(majd_fit):
    """Median and ci95 of every sampled quantity are the 2.5/50/97.5 percentiles of the stored
    HDF5 chain after the reported burn-in, in natural units."""
    res, _ = majd_fit
    burn = res["convergence"]["burn_in"]
    assert burn > 0                                               # a burn-in really is discarded
    with h5py.File(res["chain"], "r") as fh:
        chain = fh["mcmc"]["chain"][:]
    assert chain.shape[0] == res["convergence"]["steps"]
    flat = chain[burn:].reshape(-1, chain.shape[-1])
    pri = {**law_priors("steer", "majd", None), **stand_priors("steer")}
    names = [p for p in friction.FIT_PARAMS["majd"] if p != "n"] + list(STAND_PARAMS)     # n held (priors.yaml)
    assert res["fixed"] == {"n": 1.6} and "n" not in res["parameters"]
    cols = {name: pri[name].theta(flat[:, j]) for j, name in enumerate(names)}
    cols["noise_rad"] = np.exp(flat[:, len(cols)])
    cols_n = res["fixed"]["n"]
    # sigma and omega_c derived from each sample's stiction peak
    cols["sigma"], cols["omega_c"] = friction.majd_from_peak(cols["f_c"], cols["h_peak"], cols["v_peak"], cols_n)
    for name, col in cols.items():
        p = res["parameters"][name]
        lo, med, hi = np.percentile(col, [2.5, 50, 97.5])
        assert p["median"] == pytest.approx(med, rel=1e-9), name
        assert p["ci95_low"] == pytest.approx(lo, rel=1e-9), name
        assert p["ci95_high"] == pytest.approx(hi, rel=1e-9), name
    releases = res["release_angles"] + res["release_shifts_s"]
    assert len(releases) == 6
    for a, j in zip(releases, range(len(names) + 1, chain.shape[-1])):
        lo, med, hi = np.percentile(flat[:, j], [2.5, 50, 97.5])
        assert (a["ci95_low"], a["median"], a["ci95_high"]) == pytest.approx((lo, med, hi), rel=1e-9)


def test_ess_and_bic_parameter_count_of_a_majd_fit(majd_fit):
    """ESS counts every walker: n_walkers x (steps - burn-in) / tau; the BIC counts the four sampled
    Majd parameters (n is held by its point prior), the stand's two, the noise level and the three releases' sampled angles and
    instants (sigma and omega_c, derived from the sampled stiction peak, are not counted)."""
    res, _ = majd_fit
    conv = res["convergence"]
    n_after = conv["steps"] - conv["burn_in"]
    assert conv["n_walkers"] == 32
    assert conv["ess_min"] == pytest.approx(conv["n_walkers"] * n_after / conv["max_tau"], rel=1e-9)
    for name, p in res["parameters"].items():
        if not p.get("derived"):                # sigma, omega_c: functions of the sampled ones
            assert p["ess"] == pytest.approx(conv["n_walkers"] * n_after / p["tau_steps"], rel=1e-9), name
    st = res["fit"]
    assert st["n_params"] == 4 + 2 + 1 + 3 + 3
    assert st["bic"] == pytest.approx(13 * np.log(st["n_obs"]) - 2 * st["loglik_max"], rel=1e-12)


def test_sharply_identified_parameters_are_not_flagged_weak(majd_fit):
    res, _ = majd_fit
    for name in ("f_w", "f_c", "noise_rad"):
        p = res["parameters"][name]
        assert p["identifiability"] < WEAK_IDENTIFIABILITY and p["weakly_identified"] is False, (name, p)
    assert not any(n.startswith(("f_w:", "f_c:")) and "weakly identified" in n for n in res["notes"])
    for name, p in res["parameters"].items():
        if p.get("derived"):                    # sigma, omega_c: from the peak, no prior of their own
            assert p["identifiability"] is None and p["weakly_identified"] is False
            continue
        assert p["weakly_identified"] == (p["identifiability"] > WEAK_IDENTIFIABILITY), name


def test_a_posterior_that_fills_its_prior_is_flagged_weak():
    """summarize() on a hand-made chain: c drawn from its prior (posterior = prior) is weakly
    identified; the noise level, held within a few percent, is not."""
    segs = segments_from_arrays(synthetic_stand("viscous", {"c": 0.3}, seed=3, angles=(0.6, -0.5), duration=1.0))
    problem = FrictionProblem("steer_stand", "viscous", segs, law_priors("steer", "viscous"), dt=5e-3)
    lsq = least_squares_fit(problem, seed=0)
    u0 = np.concatenate([lsq["x"][:problem.n_law], [np.log(lsq["sigma_hat"])], lsq["x"][problem.n_law:]])
    rng = np.random.default_rng(0)
    n_steps, n_walkers = 30, 10
    chain = u0 + 1e-3 * rng.standard_normal((n_steps, n_walkers, problem.ndim))
    chain[..., 0] = problem.priors[0].sample_u(rng, n_steps * n_walkers).reshape(n_steps, n_walkers)
    logp = problem.log_prob(chain.reshape(-1, problem.ndim)).reshape(n_steps, n_walkers)
    post = {"chain": chain, "log_prob": logp, "burn": 5, "tau": np.full(problem.ndim, 2.0), "converged": True,
            "acceptance": np.full(n_walkers, 0.3), "n_steps": n_steps, "resumed_from": 0, "n_walkers": n_walkers,
            "autocorr_multiple": 5.0, "max_steps": n_steps, "chain_path": "none.h5", "adapt_schedule": []}
    res, _ = summarize(problem, lsq, post, n_waic_draws=20)
    c, noise = res["parameters"]["c"], res["parameters"]["noise_rad"]
    assert c["identifiability"] > 0.9 and c["weakly_identified"] is True
    assert any(n.startswith("c: weakly identified") for n in res["notes"])
    assert noise["identifiability"] < 0.1 and noise["weakly_identified"] is False


def test_comparison_reports_unconverged_fits_as_such():
    def result(law, bic, converged):
        r = {"joint": "steer", "law": law, "recording": "r",
             "fit": {"n_params": 3, "n_obs": 100, "rmse_rad": 1e-3, "loglik_max": 0.0, "bic": bic, "waic": bic}}
        if converged is not None:
            r["convergence"] = {"converged": converged}
        return r

    table = comparison([result("viscous", 10.0, False), result("majd", 5.0, True),
                          result("coulomb_viscous", 7.0, None)])
    conv = dict(zip(table["law"], table["converged"]))
    assert conv == {"viscous": False, "majd": True, "coulomb_viscous": False}


def test_chain_resumes_from_hdf5_and_a_seed_reproduces_it(tmp_path):
    segs = synthetic_stand("viscous", {"c": 0.3}, seed=3, angles=(0.6, -0.5), duration=2.0)
    kw = dict(seed=9, walkers=8, autocorr_multiple=1e6, chunk=20, min_steps=20)
    # uninterrupted run to 60 steps
    full, _ = fit_segments("steer_stand", "viscous", segs, tmp_path / "full.h5", None, max_steps=60, **kw)
    assert full["convergence"]["converged"] is False and full["convergence"]["steps"] == 60
    assert any("NOT CONVERGED" in n for n in full["notes"])
    # interrupted after 40 steps (a smaller cap stands in for the kill), then resumed to 60
    part, _ = fit_segments("steer_stand", "viscous", segs, tmp_path / "part.h5", None, max_steps=40, **kw)
    assert part["convergence"]["steps"] == 40
    resumed, _ = fit_segments("steer_stand", "viscous", segs, tmp_path / "part.h5", None, max_steps=60, **kw)
    assert resumed["convergence"]["resumed_from_steps"] == 40 and resumed["convergence"]["steps"] == 60
    with h5py.File(tmp_path / "full.h5", "r") as a, h5py.File(tmp_path / "part.h5", "r") as b:
        ca, cb = a["mcmc"]["chain"][:], b["mcmc"]["chain"][:]
    # c, the stand's two, the noise level and the two releases' angles and instants are
    # sampled; walkers raised to 2 ndim + 2
    assert ca.shape == cb.shape == (60, 18, 8)
    assert np.array_equal(ca, cb)                                 # same seed, same steps: same chain
    # a chain of different data is refused, not silently continued
    other = synthetic_stand("viscous", {"c": 0.5}, seed=4, angles=(0.6, -0.5), duration=2.0)
    with pytest.raises(RoboballError, match="different fit"):
        fit_segments("steer_stand", "viscous", other, tmp_path / "part.h5", None, max_steps=80, **kw)


def test_model_comparison_prefers_the_true_law(tmp_path):
    cv = dict(ROBOT.friction_table1["coulomb_viscous"])
    true = {"mu_s": cv["mu_s"], "mu_d": cv["mu_d"], "c": cv["c"]}
    segs = synthetic_stand("coulomb_viscous", {**true, "v_tol": cv["v_tol"]}, seed=21, angles=(0.8, -0.7),
                           duration=3.0)
    kw = dict(seed=2, walkers=16, autocorr_multiple=1e6, max_steps=20, chunk=20, min_steps=20)
    fits = []
    for law in ("viscous", "coulomb_viscous"):
        res, _ = fit_segments("steer_stand", law, segs, tmp_path / f"{law}.h5", None, **kw)
        fits.append(res)
    table = comparison(fits)
    assert list(table["law"])[0] == "coulomb_viscous"
    bic = dict(zip(table["law"], table["bic"]))
    assert bic["viscous"] - bic["coulomb_viscous"] > 100
    rmse = dict(zip(table["law"], table["rmse_rad"]))
    assert rmse["coulomb_viscous"] < 2e-3 < rmse["viscous"]
    assert {"loglik_map", "loglik", "waic", "delta_bic", "n_params", "converged"} <= set(table.columns)
    # fixed v_tol is reported, and the fitted Coulomb levels are the true ones
    assert fits[1]["fixed"] == {"v_tol": cv["v_tol"]}
    assert fits[1]["parameters"]["mu_d"]["lsq"] == pytest.approx(true["mu_d"], rel=0.05)


def test_priors_file_and_blocks_are_validated():
    pri = law_priors("steer", "majd", None)
    assert set(pri) == {"f_w", "f_c", "h_peak", "v_peak"}        # Majd's law by its stiction peak
    # n held by a point prior at Table I's drive value (the swings do not pin it; priors.yaml)
    for joint in ("steer", "drive"):
        assert law_fixed(joint, "majd") == {"n": ROBOT.friction_table1["majd_drive"]["n"]}
        assert law_fixed(joint, "viscous") == {}
    # a point prior is a value, not a distribution: a start or bounds with it are refused
    with pytest.raises(ConfigError):
        law_priors("steer", "majd", {**{k: {"type": "loguniform", "low": 0.001, "high": 20.0, "start": 0.5}
                                       for k in ("f_w", "f_c", "h_peak", "v_peak")},
                                    "n": {"type": "fixed", "value": 1.6, "start": 1.6}})
    table1 = ROBOT.friction_table1
    for joint, law, key in (("steer", "viscous", "viscous"), ("steer", "majd", "majd_steer"),
                            ("drive", "majd", "majd_drive")):
        paper = dict(table1[key])
        if law == "majd":
            paper["h_peak"], paper["v_peak"] = map(float, friction.majd_to_peak(
                paper["f_c"], paper["sigma"], paper["omega_c"], paper["n"]))
        for name, p in law_priors(joint, law, None).items():
            # the paper's values are inside (Table I's steer n = 1, the law's limit, within 1e-6)
            assert p.low - 1e-6 <= paper[name] <= p.high, (joint, law, name)
    for joint in ("steer", "drive"):
        stand = stand_priors(joint)
        assert set(stand) == set(STAND_PARAMS) and all(p.linear for p in stand.values())
        assert stand["delta_i"].low < 0 < stand["delta_i"].high and stand["rest_offset"].low < 0 < stand["rest_offset"].high
    with pytest.raises(ConfigError, match="no prior for"):
        law_priors("steer", "majd", {"f_w": {"type": "loguniform", "low": 0.01, "high": 1.0, "start": 0.1}})
    with pytest.raises(ConfigError, match="low"):
        law_priors("steer", "viscous", {"c": {"type": "loguniform", "low": 1.0, "high": 0.1, "start": 0.5}})
    with pytest.raises(ConfigError, match="c"):
        law_priors("steer", "viscous", {"c": {"type": "gaussian", "low": 0.1, "high": 1.0, "start": 0.5}})


def test_prior_density_on_the_sampling_coordinate():
    """Drawn u-samples follow logpdf_u (checked on a histogram) for each prior type and shift."""
    rng = np.random.default_rng(0)
    for spec, shift in (({"type": "loguniform", "low": 0.01, "high": 10.0}, 0.0),
                        ({"type": "uniform", "low": 1.0, "high": 5.0}, 1.0),
                        ({"type": "lognormal", "median": 0.3, "sigma_log": 0.7, "low": 0.05, "high": 3.0}, 0.0)):
        p = Prior.from_spec("x", spec, shift=shift)
        u = p.sample_u(rng, 200000)
        hist, edges = np.histogram(u, bins=40, density=True)
        mid = 0.5 * (edges[1:] + edges[:-1])
        dens = np.exp(p.logpdf_u(mid))
        dens /= np.sum(dens * np.diff(edges))
        assert np.max(np.abs(hist - dens)) < 0.05 * np.max(dens)


def test_bad_segments_are_one_line_errors():
    t = np.linspace(0, 5, 400)
    with pytest.raises(RoboballError, match="only 2 samples after the release"):
        segments_from_arrays([(t, np.sin(t), 4.98)])
    with pytest.raises(RoboballError, match="times but"):
        segments_from_arrays([(t, np.sin(t)[:-1], 1.0)])
    with pytest.raises(RoboballError, match="stand recording"):
        fit_segments("shell_rock", "viscous", [(t, np.sin(t), 1.0)], "x.h5")


def test_release_angles_stay_inside_the_joint_limits():
    """The real steer-stand log's third release is held at 0.92 rad, 0.08 rad below the steer
    joint's stop (1.0 rad, configs/robot.yaml).  The reduced model has no stop; Drake has, so a
    fitted release angle past it (the pipeline once fitted 1.158 rad) threw the Drake pendulum
    across its range in 40 ms in Fig. 7.  The release-angle support is clipped to the limits."""
    segs = segments_from_arrays(synthetic_stand("viscous", {"c": 0.3}, seed=3, angles=(0.92, -1.45, 0.5), duration=1.5))
    problem = FrictionProblem("steer_stand", "viscous", segs, law_priors("steer", "viscous"), robot=ROBOT)
    steer = ROBOT.joints["steer"]
    assert problem.q0_high[0] == steer["upper_rad"] and problem.q0_low[1] == steer["lower_rad"]
    assert problem.q0_high[2] == pytest.approx(segs[2].y_release + RELEASE_HALF_WIDTH_RAD)
    lo, hi = problem.lsq_bounds()
    k = problem.n_phys                                          # the angles, then the instants' shifts
    assert hi[k] == steer["upper_rad"] and lo[k + 1] == steer["lower_rad"]
    c_u, noise_u = float(problem.priors[0].u_of(0.3)), float(problem.noise_prior.u_of(1e-3))
    u = np.array([[c_u, noise_u, 0.99, -1.45, 0.5, 0.0, 0.0, 0.0], [c_u, noise_u, 1.01, -1.45, 0.5, 0.0, 0.0, 0.0]])
    assert np.isfinite(problem.log_prior(u[:1]))[0] and problem.log_prior(u[1:])[0] == -np.inf
    # a release recorded past the stop cannot be fitted: a one-line error naming it
    t = np.linspace(0, 3, 300)
    with pytest.raises(RoboballError, match=r"release 1 starts at 1.600 rad, outside the steer joint's limits"):
        FrictionProblem("steer_stand", "viscous", segments_from_arrays([(t, np.cos(t), {"t_release_s": 0.0, "y_release": 1.6})]),
                          law_priors("steer", "viscous"), robot=ROBOT)


def test_adaptive_chain_resumes_identically_across_its_stages(tmp_path):
    """Killed inside the DE stage, inside the first independence stage and in production, the
    resumed chain is the uninterrupted one step for step (the proposal of each stage is refitted
    from the stored chain, and the random state comes from the HDF5 file)."""
    segs = segments_from_arrays(synthetic_stand("viscous", {"c": 0.3}, seed=3, angles=(0.6, -0.5), duration=2.0))
    problem = FrictionProblem("steer_stand", "viscous", segs, law_priors("steer", "viscous"), dt=5e-3)
    lsq = least_squares_fit(problem, seed=0)
    kw = dict(seed=4, n_walkers=14, autocorr_multiple=1e6, chunk=5, min_steps=5, adapt_schedule=(10, 20))
    full = sample_posterior(problem, lsq, tmp_path / "full.h5", max_steps=40, **kw)
    assert full["adapt_schedule"] == [10, 20] and full["burn"] >= 20     # burn-in counts from production
    for stop in (7, 15, 30):
        path = tmp_path / f"part{stop}.h5"
        sample_posterior(problem, lsq, path, max_steps=stop, **kw)
        resumed = sample_posterior(problem, lsq, path, max_steps=40, **kw)
        assert resumed["resumed_from"] == stop
        assert np.array_equal(resumed["chain"], full["chain"]), stop
    # a chain stored under another adaptation schedule is refused, not continued
    with pytest.raises(RoboballError, match="different fit"):
        sample_posterior(problem, lsq, tmp_path / "full.h5", max_steps=50, **{**kw, "adapt_schedule": (12, 20)})


def test_a_chain_killed_inside_a_chunk_resumes_from_the_last_chunk_identically(tmp_path, monkeypatch):
    """The chain is written a chunk at a time (roboball.identify.friction.backend): a fit killed
    inside a chunk leaves the file at the end of the previous chunk, readable, and the resumed
    chain is the uninterrupted one step for step.  A chain stored by emcee's own HDFBackend (one
    write per step, as before) resumes the same way."""
    import emcee

    import roboball.identify.friction.backend as B

    segs = segments_from_arrays(synthetic_stand("viscous", {"c": 0.3}, seed=3, angles=(0.6, -0.5), duration=2.0))
    problem = FrictionProblem("steer_stand", "viscous", segs, law_priors("steer", "viscous"), dt=5e-3)
    lsq = least_squares_fit(problem, seed=0)
    kw = dict(seed=4, n_walkers=14, autocorr_multiple=1e6, chunk=5, min_steps=5, adapt_schedule=(10, 20))
    full = sample_posterior(problem, lsq, tmp_path / "full.h5", max_steps=40, **kw)

    class Killed(Exception):
        pass

    save_step = B.ChunkedHDFBackend.save_step

    def killed_at_step_23(self, state, accepted):
        if self.iteration + len(self._coords) == 22:
            raise Killed
        save_step(self, state, accepted)

    path = tmp_path / "killed.h5"
    monkeypatch.setattr(B.ChunkedHDFBackend, "save_step", killed_at_step_23)
    with pytest.raises(Killed):
        sample_posterior(problem, lsq, path, max_steps=40, **kw)
    monkeypatch.undo()
    stored = emcee.backends.HDFBackend(str(path), name="mcmc", read_only=True)
    assert stored.iteration == 20 and np.array_equal(stored.get_chain(), full["chain"][:20])
    resumed = sample_posterior(problem, lsq, path, max_steps=40, **kw)
    assert resumed["resumed_from"] == 20 and np.array_equal(resumed["chain"], full["chain"])
    assert np.array_equal(resumed["acceptance"], full["acceptance"])

    # a chain written step by step by emcee's own backend is continued to the same chain
    stock = tmp_path / "stock.h5"
    monkeypatch.setattr(B, "ChunkedHDFBackend", _StockBackend)
    first = sample_posterior(problem, lsq, stock, max_steps=15, **kw)
    monkeypatch.undo()
    assert first["n_steps"] == 15
    resumed = sample_posterior(problem, lsq, stock, max_steps=40, **kw)
    assert resumed["resumed_from"] == 15 and np.array_equal(resumed["chain"], full["chain"])


class _StockBackend:
    """emcee's HDFBackend with the chunked backend's flush (a no-op: it wrote every step)."""

    def __new__(cls, *args, **kwargs):
        import emcee

        backend = emcee.backends.HDFBackend(*args, **kwargs)
        backend.flush = lambda: None
        return backend


def test_a_chain_sampled_by_other_code_or_robot_facts_is_not_resumed(tmp_path):
    """The pipeline reruns a fit when its code or the robot facts change, and the HDF5 chain
    must not carry the old posterior into it: a stored chain records the source fingerprint of
    the log-probability (handed down by the pipeline stage) and the robot facts.  Kept by a user
    (the default) it is refused; as the pipeline's cache (stale="restart") it is sampled afresh,
    giving exactly a fresh run."""
    import copy

    from roboball.config import RobotFacts
    from roboball.pipeline.codedeps import source_fingerprint
    from roboball.pipeline.friction import FIT_MODULE

    segs = segments_from_arrays(synthetic_stand("viscous", {"c": 0.3}, seed=3, angles=(0.6, -0.5), duration=2.0))
    problem = FrictionProblem("steer_stand", "viscous", segs, law_priors("steer", "viscous"), dt=5e-3)
    lsq = least_squares_fit(problem, seed=0)
    kw = dict(seed=4, n_walkers=14, autocorr_multiple=1e6, chunk=5, min_steps=5, adapt_schedule=(10, 20),
              code=source_fingerprint(FIT_MODULE))
    fresh = sample_posterior(problem, lsq, tmp_path / "fresh.h5", max_steps=30, **kw)
    # the chain of an older roboball
    sample_posterior(problem, lsq, tmp_path / "old.h5", max_steps=30, **{**kw, "code": "0000000000000000"})
    with pytest.raises(RoboballError, match="different fit \\(differs in code\\)"):
        sample_posterior(problem, lsq, tmp_path / "old.h5", max_steps=30, **kw)
    again = sample_posterior(problem, lsq, tmp_path / "old.h5", max_steps=30, stale="restart", **kw)
    assert again["resumed_from"] == 0 and np.array_equal(again["chain"], fresh["chain"])
    # other robot facts: another fit
    data = copy.deepcopy(ROBOT.data)
    data["links"]["pendulum"]["mass_kg"] *= 1.01
    heavier = FrictionProblem("steer_stand", "viscous", segs, law_priors("steer", "viscous"), dt=5e-3,
                                robot=RobotFacts(data, source="test"))
    assert heavier.fingerprint() != problem.fingerprint()


def test_independence_proposal_samples_a_known_gaussian_exactly():
    """The MH correction of IndependentT: a deliberately wrong proposal (shifted mean, wrong
    widths) still samples the target N(mu, diag(s^2))."""
    import emcee

    mu, s = np.array([1.0, -2.0, 0.5]), np.array([0.5, 2.0, 0.1])

    def log_prob(x):
        return -0.5 * np.sum(((x - mu) / s) ** 2, axis=1)

    prop = IndependentT(mu + 0.5 * s, np.diag((1.5 * s) ** 2), df=6.0, scale=1.0)
    sampler = emcee.EnsembleSampler(16, 3, log_prob, vectorize=True, moves=[(emcee.moves.MHMove(prop), 1.0)])
    sampler._random = np.random.RandomState(7)
    sampler.run_mcmc(mu + 0.1 * s * np.random.default_rng(1).standard_normal((16, 3)), 3000, progress=False)
    x = sampler.get_chain(discard=200, flat=True)
    assert np.all(np.abs(x.mean(axis=0) - mu) < 0.05 * s)                       # within 5% of each sd
    assert np.allclose(x.std(axis=0), s, rtol=0.05)
    assert 0.2 < np.mean(sampler.acceptance_fraction) < 0.9


def test_boxed_proposal_samples_a_correlated_target_exactly():
    """BoxedT: x0 drawn uniformly over its box, x1 from a t about its regression on x0; with the
    MH correction the chain samples the target (x0 ~ N(0, 1), x1 = 2 x0 + N(0, 0.3^2)), from a
    regression fitted to deliberately wrong samples."""
    import emcee

    def log_prob(x):
        return -0.5 * x[:, 0] ** 2 - 0.5 * ((x[:, 1] - 2.0 * x[:, 0]) / 0.3) ** 2

    rng = np.random.default_rng(3)
    x0 = rng.uniform(-1, 1, 400)
    wrong = np.column_stack([x0, 1.5 * x0 + 0.2 + 0.5 * rng.standard_normal(400)])
    prop = BoxedT(wrong, {0: (-5.0, 5.0)}, df=6.0, scale=1.0)
    sampler = emcee.EnsembleSampler(16, 2, log_prob, vectorize=True, moves=[(emcee.moves.MHMove(prop), 1.0)])
    sampler._random = np.random.RandomState(7)
    sampler.run_mcmc(0.1 * rng.standard_normal((16, 2)), 20000, progress=False)    # tau about 17 steps
    x = sampler.get_chain(discard=500, flat=True)
    assert abs(x[:, 0].mean()) < 0.06 and abs(x[:, 0].std() - 1.0) < 0.06
    assert abs(np.polyfit(x[:, 0], x[:, 1], 1)[0] - 2.0) < 0.06
    assert abs(np.std(x[:, 1] - 2.0 * x[:, 0]) - 0.3) < 0.02


def test_a_weak_coordinate_is_boxed_over_its_whole_prior():
    """The box of a coordinate the adaptation spreads over is the prior's support, not the
    samples' range: the walkers may not yet have reached the far end of a plateau."""
    from roboball.identify.friction.moves import weak_boxes
    from roboball.identify.friction.priors import Prior

    priors = [Prior("mu_s", "loguniform", 0.001, 5.0), Prior("rest_offset", "uniform", -1.0, 2.0, linear=True)]
    rng = np.random.default_rng(0)
    X = np.column_stack([rng.uniform(np.log(0.001), np.log(0.07), 500), 1.0 + 0.01 * rng.standard_normal(500)])
    boxes = weak_boxes(X, priors)
    assert set(boxes) == {0}
    assert boxes[0] == pytest.approx((np.log(0.001), np.log(5.0)))


def test_the_identification_imports_nothing_from_the_pipeline():
    """identify/ is below pipeline/: the pipeline stage hands the code fingerprint down
    (roboball.pipeline.friction), the fit never reaches up for it."""
    import ast
    from pathlib import Path

    import roboball.identify

    offenders = []
    for path in Path(roboball.identify.__file__).parent.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module or ""] if isinstance(node, ast.ImportFrom) else []
            offenders += [f"{path.name}:{node.lineno}" for n in names if n.startswith("roboball.pipeline")]
    assert not offenders, offenders


# ---------------------------------------------------------------------------------------------
# The calibrated stand
# ---------------------------------------------------------------------------------------------
CALIBRATION = {"added_inertia": 0.08, "rest_offset": 0.012, "shifts": (0.06, -0.04)}


def test_the_calibrated_stand_recovers_added_inertia_offset_and_release_instants(tmp_path):
    """Swings of a stand with 0.08 kg m^2 more inertia than its URDF (12% slower), resting 12 mrad
    off the URDF's rest and let go 60 ms late / 40 ms early: the fit recovers the inertia, the
    offset and the instants within their intervals and tracks the swings to the noise, while the
    stand as its URDF says (delta_i and rest_offset held at 0, the finder's instants) cannot
    follow them."""
    segs = segments_from_arrays(synthetic_stand("viscous", {"c": 0.3}, seed=5, angles=(0.9, -0.8), duration=4.0,
                                                **CALIBRATION))
    res, _ = fit_segments("steer_stand", "viscous", segs, tmp_path / "cal.h5", None, seed=1, walkers=20,
                          autocorr_multiple=8, max_steps=1200, chunk=50, min_steps=50)
    p = res["parameters"]
    assert res["stand_calibrated"] is True and res["convergence"]["converged"], res["notes"]
    for name, truth in (("delta_i", CALIBRATION["added_inertia"]), ("rest_offset", CALIBRATION["rest_offset"]),
                        ("c", 0.3)):
        assert p[name]["ci95_low"] < truth < p[name]["ci95_high"], (name, p[name])
    assert p["delta_i"]["unit"] == "kg m^2" and p["rest_offset"]["unit"] == "rad"
    for shift, truth in zip(res["release_shifts_s"], CALIBRATION["shifts"]):
        # to the millisecond: 1 mrad noise on 4 rad/s swings pins the instant to a fraction of a
        # millisecond, below the 2.5 ms step's own timing error
        assert shift["median"] == pytest.approx(truth, abs=1e-3) and shift["unit"] == "s", shift
    assert res["fit"]["rmse_rad"] < 1.5e-3
    # the URDF's stand: off by a large fraction of the swings
    plain = FrictionProblem("steer_stand", "viscous", segs, law_priors("steer", "viscous"), shift_half_width=0.0)
    assert plain.fixed["delta_i"] == plain.fixed["rest_offset"] == 0.0 and not plain.stand_names
    assert least_squares_fit(plain, seed=0)["rms"] > 0.05


def test_fixed_calibration_is_held_and_reported():
    """`fixed` holds the stand's parameters like a law's: not sampled, reported under `fixed`."""
    segs = segments_from_arrays(synthetic_stand("viscous", {"c": 0.3}, seed=3, angles=(0.6, -0.5), duration=1.0))
    problem = FrictionProblem("steer_stand", "viscous", segs, law_priors("steer", "viscous"), stand=stand_priors("steer"),
                              fixed={"delta_i": 0.05})
    assert problem.stand_names == ["rest_offset"] and problem.phys_names == ["c", "rest_offset"]
    params = problem.law_params(np.array([[np.log(0.3), 0.01]]))
    assert params["delta_i"] == 0.05 and params["rest_offset"][0] == 0.01


# ---------------------------------------------------------------------------------------------
# Majd's law through the peak of its sigma term
# ---------------------------------------------------------------------------------------------
def test_majd_is_sampled_through_its_stiction_peak():
    """h_peak and v_peak are the hump's torque and speed where its sigma term peaks (found here
    numerically), mapped to (sigma, omega_c) and back exactly, accurate as n -> 1 where sigma
    alone cancels; at a fixed peak the law has a limit at n = 1 (no ridge to infinity)."""
    x = np.linspace(0.0, 40.0, 400001)
    f_c, sigma, w_c = 0.4, 3.0, 0.1
    for n in (1.000001, 1.01, 1.5, 2.0, 5.0):
        k = np.argmax(sigma * (np.exp(-x) - np.exp(-n * x)))
        h, v = friction.majd_to_peak(f_c, sigma, w_c, n)
        assert v == pytest.approx(x[k] * w_c, abs=2e-5), n
        # (to the grid's 1e-4 in x: the Coulomb term still rises there)
        assert h == pytest.approx(f_c * (1 - np.exp(-n * x[k])) + sigma * (np.exp(-x[k]) - np.exp(-n * x[k])), rel=1e-4)
        back = friction.majd_from_peak(f_c, h, v, n)
        assert back == pytest.approx((sigma, w_c), rel=1e-9), n
    v = np.linspace(-2.0, 2.0, 401)
    f_w, h, v_p = 0.2, 0.5, 0.1
    xv = np.abs(v) / v_p
    limit = -(f_w * v + (f_c * (1 - np.exp(-xv)) + np.e * (h - (1 - 1 / np.e) * f_c) * xv * np.exp(-xv)) * np.sign(v))
    for n in (1.001, 1.00001):
        law = friction.torque("majd", v, friction.natural_params("majd", dict(f_w=f_w, f_c=f_c, h_peak=h, v_peak=v_p, n=n)))
        assert np.max(np.abs(law - limit)) < 10 * (n - 1), n
    # below the Coulomb term's own rise there is no stiction peak (sigma < 0): still friction as
    # long as it never pushes; far below, it would push at low speed and is outside the support
    for h_low, pushes in ((0.2, False), (0.01, True)):
        low = friction.natural_params("majd", dict(f_w=0.0, f_c=f_c, h_peak=h_low, v_peak=v_p, n=2.0))
        assert low["sigma"] < 0 and bool(friction.admissible("majd", low)) is not pushes
        assert bool(np.any(friction.torque("majd", v, low) * v > 1e-12)) is pushes
    problem = FrictionProblem("steer_stand", "majd", segments_from_arrays(synthetic_stand(
        "viscous", {"c": 0.3}, seed=3, angles=(0.6,), duration=1.0)), law_priors("steer", "majd"),
        fixed=law_fixed("steer", "majd"))
    assert problem.law_names == ["f_w", "f_c", "h_peak", "v_peak"]


# ---------------------------------------------------------------------------------------------
# Model comparison: an unconverged chain is never recommended
# ---------------------------------------------------------------------------------------------
def test_an_unconverged_chain_is_never_recommended():
    def result(law, bic, converged):
        return {"joint": "steer", "law": law, "recording": "r", "convergence": {"converged": converged},
                "fit": {"n_params": 3, "n_obs": 100, "rmse_rad": 1e-3, "loglik_max": 0.0, "bic": bic, "waic": bic}}

    table = comparison([result("majd", -100.0, False), result("coulomb_viscous", -80.0, True),
                        result("viscous", -50.0, True)])
    assert dict(zip(table["law"], table["recommended"])) == {"majd": False, "coulomb_viscous": True, "viscous": False}
    best, why = recommendation(table)
    assert best.law == "coulomb_viscous"
    assert why == "by dBIC = 30.0 (majd, of lower BIC, left out: its chain did not converge)"
    none = comparison([result("majd", -100.0, False)])
    assert not none["recommended"].any()
    best, why = recommendation(none)
    assert best is None and why == "no recommendation: no chain converged (majd)"


# ---------------------------------------------------------------------------------------------
# The real steer-stand log
# ---------------------------------------------------------------------------------------------
REAL_STEER = REAL_DATA / "steering_static_stand_response.csv"
RMS_BOUND_RAD = 0.05


@pytest.fixture(scope="module")
def real_fits(tmp_path_factory):
    """The three steer laws fitted to the real steer-stand log as the pipeline does (its
    importer and release finder, configs/priors.yaml, the pipeline's walkers, autocorrelation
    multiple, step cap and seed)."""
    if not REAL_STEER.exists():
        pytest.skip(f"real steer-stand log not found at {REAL_STEER}")
    from roboball.ingest.importers import read_any
    from roboball.ingest.recording import normalise
    from roboball.ingest.releases.find import require_releases

    rec = normalise(read_any(REAL_STEER, kind="steer_stand"))
    rels = [r.as_dict() for r in require_releases(rec)]
    segs = segments_from_arrays([(rec.time, rec.main_values(), r) for r in rels])
    cfg = load_yaml(CONFIG_DIR / "config.yaml")
    fr = cfg["friction"]
    tmp = tmp_path_factory.mktemp("real")
    return rec, rels, {law: fit_segments("steer_stand", law, segs, tmp / f"{law}.h5", None, seed=cfg["seed"],
                                   walkers=fr["walkers"], autocorr_multiple=fr["autocorr_multiple"],
                                   max_steps=fr["max_steps"], source="real_steer_stand")[0]
                 for law in fr["steer_laws"]}


@pytest.mark.slow       # three chains on the real steer log (about 30 s); run by make test-slow and CI
def test_every_real_posterior_converges(real_fits):
    """At least 50 autocorrelation times after burn-in for every law, Majd included (its chain
    stopped at 14 before the law was sampled by its stiction peak and the stand calibrated)."""
    _, _, fits = real_fits
    for law, res in fits.items():
        c = res["convergence"]
        assert c["converged"] and c["chain_over_tau"] >= 50, (law, c, res["notes"])
        assert not any("NOT CONVERGED" in n for n in res["notes"]), law


@pytest.mark.slow       # two Coulomb + viscous chains on the real steer log (about 60 s)
@pytest.mark.parametrize("seed", [0, 2])
def test_the_real_coulomb_viscous_posterior_converges_at_other_seeds(real_fits, tmp_path, seed):
    """Convergence is not the pipeline seed's luck: at seeds 0 and 2 this chain stopped at the
    3000-step cap (tau 138 and 92) while the adaptation froze a proposal over the part of mu_s's
    plateau its walkers had reached."""
    rec, rels, _ = real_fits
    segs = segments_from_arrays([(rec.time, rec.main_values(), r) for r in rels])
    fr = load_yaml(CONFIG_DIR / "config.yaml")["friction"]
    res, _ = fit_segments("steer_stand", "coulomb_viscous", segs, tmp_path / "c.h5", None, seed=seed,
                          walkers=fr["walkers"], autocorr_multiple=fr["autocorr_multiple"],
                          max_steps=fr["max_steps"], source="real_steer_stand")
    c = res["convergence"]
    assert c["converged"] and c["chain_over_tau"] >= 50, c


@pytest.mark.slow       # shares the three real chains above
def test_the_best_law_tracks_the_real_swings_in_drake(real_fits):
    """The recommended law (lowest BIC of a converged chain) fits the real log within 50 mrad
    RMS, in the reduced model and simulated in Drake on the calibrated stand as Fig. 7 draws it;
    the stand it calibrates swings slower than its URDF (added inertia 0.03-0.08 kg m^2) and
    rests within 10 mrad of the URDF's rest."""
    from roboball.sim.scenarios import simulate_calibrated_stand
    from roboball.sim.spec import SimSpec

    rec, rels, fits = real_fits
    best, _ = recommendation(comparison(list(fits.values())))
    res = fits[best.law]
    assert res["fit"]["rmse_rad"] <= RMS_BOUND_RAD
    p = res["parameters"]
    assert 0.03 < p["delta_i"]["median"] < 0.08 and abs(p["rest_offset"]["median"]) < 0.01
    law = {k: v["median"] for k, v in p.items() if k in friction.PARAMS[best.law]}
    spec = SimSpec(kind="steer_stand", friction={"steer": best.law, "drive": "none"},
                   friction_params={"steer": {**res["fixed"], **law}},
                   added_inertia={"steer": p["delta_i"]["median"]})
    residuals = []
    for r, angle, shift in zip(rels, res["release_angles"], res["release_shifts_s"]):
        t_rel, t_end = r["t_release_s"], r["t_end_s"]
        df = simulate_calibrated_stand(spec, angle["median"], t_end - t_rel - shift["median"],
                                       rest_offset=p["rest_offset"]["median"], sample_rate_hz=200.0)
        m = (rec.time >= t_rel) & (rec.time <= t_end)
        y = np.interp(rec.time[m] - t_rel - shift["median"], df.time_s, df.steer_angle_rad)
        residuals.append(rec.main_values()[m] - y)
    assert np.sqrt(np.mean(np.concatenate(residuals) ** 2)) <= RMS_BOUND_RAD
