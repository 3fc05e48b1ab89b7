"""The RK4 step of a friction fit on a quiet log: small enough that its error biases no parameter
and that the likelihood is smooth enough for the sampler (roboball.identify.friction.timestep)."""
import numpy as np
import pytest

from roboball.config import CONFIG_DIR, load_yaml
from roboball.errors import RoboballError
from roboball.identify.friction.fit import fit_segments
from roboball.identify.friction.lsq import least_squares_fit
from roboball.identify.friction.priors import law_fixed, law_priors, stand_priors
from roboball.identify.friction.problem import FrictionProblem
from roboball.identify.friction.segments import segments_from_arrays
from roboball.identify.friction.timestep import DT_CANDIDATES, DT_TOLERANCE, choose_dt
from roboball.ingest.recording import normalise, read_recording
from roboball.ingest.releases.find import require_releases
from conftest import REPO

# The campaign's steer stand: the twin's, 0.8 mrad of fitted noise (Table I).
QUIET_STAND = REPO / "raw_data" / "steer_stand" / "steer_stand_r1.csv"
PRIORS = CONFIG_DIR / "priors.yaml"
LAW = "coulomb_viscous"


@pytest.fixture(scope="module")
def quiet_segments():
    rec = normalise(read_recording(QUIET_STAND))
    return segments_from_arrays([(rec.time, rec.main_values(), r.as_dict()) for r in require_releases(rec)],
                                source=QUIET_STAND.name)


def _problem(segs):
    return FrictionProblem("steer_stand", LAW, segs, law_priors("steer", LAW, PRIORS),
                           fixed=law_fixed("steer", LAW, PRIORS), dt=DT_CANDIDATES[0],
                           stand=stand_priors("steer", PRIORS))


def _jitter(problem, lsq, j, dt, n=61):
    """Standard deviation of the log-likelihood about its quadratic fit along parameter j, over
    +-2 Laplace standard deviations around the least-squares optimum."""
    x, sd = lsq["x"], np.sqrt(np.diag(lsq["cov"]))
    s = np.linspace(-2.0, 2.0, n)
    X = np.repeat(x[None], n, axis=0)
    X[:, j] += s * sd[j]
    r = problem.residuals(X, dt=dt)
    ll = -0.5 * np.sum(r * r, axis=1) / lsq["sigma_hat"] ** 2
    return float(np.std(ll - np.polyval(np.polyfit(s, ll, 2), s)))


def test_a_quiet_stand_log_gets_a_step_that_neither_biases_nor_roughens_the_posterior(quiet_segments):
    """Coulomb + viscous on the campaign's quiet steer stand.  Eq. 2's torque jumps at the
    stiction band's edges; stepped across, the log-likelihood jittered by 1.0-1.7 about a
    quadratic (along mu_d, c, delta_i and rest_offset) at 0.625 ms and 0.23-0.64 at 0.156 ms, the
    step it then needed, where the chain converged in 1200-1400 steps at acceptance 0.2.  With
    the edges located (roboball.reduced.kernel) the jitter is 0.003-0.03 at every candidate step,
    so the step is set by its bias alone: 1.25 ms (0.11 sd), where the chain converges in 1000
    steps at acceptance 0.42."""
    problem = _problem(quiet_segments)
    lsq = least_squares_fit(problem, seed=0)
    dt, info = choose_dt(problem, lsq)
    assert dt >= 1.25e-3 and info["max_shift_sd"] <= DT_TOLERANCE, info
    jitter = {problem.names[j]: _jitter(problem, lsq, j, dt) for j in range(1, 5)}
    assert max(jitter.values()) < 0.1, jitter


@pytest.mark.slow       # the pipeline's chain on the quiet log (about 20 s alone)
def test_the_campaigns_quiet_coulomb_viscous_chain_converges(quiet_segments, tmp_path):
    """With the pipeline's settings and seed the chain converges inside the step cap and carries
    no integration-bias note (before the two smaller steps: 3000 steps, 33 autocorrelation
    times of the 50 asked, and a 0.52 sd bias note)."""
    cfg = load_yaml(CONFIG_DIR / "config.yaml")
    fr = cfg["friction"]
    res, _ = fit_segments("steer_stand", LAW, quiet_segments, tmp_path / "c.h5", PRIORS, seed=cfg["seed"],
                          walkers=fr["walkers"], autocorr_multiple=fr["autocorr_multiple"],
                          max_steps=fr["max_steps"], source=QUIET_STAND.name)
    c = res["convergence"]
    assert c["converged"] and c["chain_over_tau"] >= fr["autocorr_multiple"], (c, res["notes"])
    assert res["notes"] == [], res["notes"]


def test_the_adaptation_runs_at_its_own_step_and_production_at_the_fits(tmp_path):
    """With an adaptation step the stored log-probabilities are that step's up to the end of the
    adaptation and the fit's own after it (recomputed where production starts, so that no
    Metropolis ratio mixes the two), the problem keeps its step, and a chain stopped at the
    switch resumes into the uninterrupted one step for step."""
    from test_friction_fit import synthetic_stand

    from roboball.identify.friction.sampler import sample_posterior

    segs = segments_from_arrays(synthetic_stand("coulomb_viscous", {"mu_s": 0.5, "mu_d": 0.4, "c": 0.2}, seed=5,
                                                angles=(0.6, -0.5), duration=2.0))
    problem = FrictionProblem("steer_stand", LAW, segs, law_priors("steer", LAW), fixed=law_fixed("steer", LAW),
                              dt=1.25e-3)
    lsq = least_squares_fit(problem, seed=0)
    kw = dict(seed=4, n_walkers=16, autocorr_multiple=1e6, chunk=5, min_steps=5, adapt_schedule=(10, 20),
              adapt_dt=5e-3)
    full = sample_posterior(problem, lsq, tmp_path / "full.h5", max_steps=30, **kw)
    assert problem.dt == 1.25e-3
    chain, lp = full["chain"], full["log_prob"]
    for step, dt in ((19, 5e-3), (20, 1.25e-3), (29, 1.25e-3)):
        problem.dt = dt
        assert np.allclose(problem.log_prob(chain[step]), lp[step], rtol=0, atol=1e-9), step
    problem.dt = 1.25e-3
    assert not np.allclose(problem.log_prob(chain[19]), lp[19])      # the two steps' posteriors differ here
    sample_posterior(problem, lsq, tmp_path / "part.h5", max_steps=20, **kw)
    resumed = sample_posterior(problem, lsq, tmp_path / "part.h5", max_steps=30, **kw)
    assert resumed["resumed_from"] == 20 and np.array_equal(resumed["chain"], chain)
    # a chain adapted at another step is another fit's: refused, not continued
    with pytest.raises(RoboballError, match="different fit"):
        sample_posterior(problem, lsq, tmp_path / "full.h5", max_steps=40, **{**kw, "adapt_dt": 2.5e-3})
