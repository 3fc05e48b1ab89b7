"""Time-step convergence of the Drake ramp descent (issue 7, point 2: no accuracy given up
silently).  Tolerance: eq. 12's PME of a run against a reference at a quarter of its step within
1%, the issue's criterion, for every contact model at the step the pipeline uses
(configs/config.yaml ramp.dt_s) and for point contact at the 10 ms step its speed figure uses."""

import pytest
import yaml

from roboball.sim.convergence import step_study

TOL_PERCENT = 1.0
from conftest import REPO
CONFIG = REPO / "configs" / "config.yaml"


def pipeline_ramp_dt() -> float:
    return float(yaml.safe_load(CONFIG.read_text())["ramp"]["dt_s"])


@pytest.mark.parametrize("contact", ["point", "injected", "hydroelastic"])
def test_ramp_at_the_pipeline_step_is_within_1_percent_of_a_quarter_step_reference(contact):
    (r,) = step_study(contact, [pipeline_ramp_dt()], duration=2.0)
    assert r.within(TOL_PERCENT), f"{contact}: PME {r.pme_vs_ref_percent:+.2f}% against dt/4 at dt {r.dt_s} s"


def test_point_contact_at_10_ms_is_within_1_percent_of_its_quarter_step_reference():
    (r,) = step_study("point", [0.01], duration=2.0)
    assert r.within(TOL_PERCENT), f"PME {r.pme_vs_ref_percent:+.2f}% against 2.5 ms"


def test_the_study_sees_the_hydroelastic_step_error_it_guards_against():
    """Hydroelastic rolling under `lagged` converges to first order (about 0.9% PME per ms of
    step, measured): at 4 ms the error is several percent.  The study must report it, or the
    tests above could pass on a study that measures nothing."""
    (r,) = step_study("hydroelastic", [0.004], duration=2.0)
    assert r.pme_vs_ref_percent < -2.0, r
