"""The t and chi-square quantiles of roboball.metrics are scipy.stats' to the bit (the shell
regressions' and the volume law's intervals use them without importing scipy.stats), and the
stages that use them no longer import scipy.stats."""
import subprocess
import sys

import numpy as np
from scipy import stats

from roboball.metrics import chi2_quantile, t_quantile


def test_t_quantiles_are_scipy_stats_to_the_bit():
    for dof in (1, 2, 3, 4, 7, 12, 30, 200):
        for p in (0.5, 0.8, 0.9, 0.95, 0.975, 0.995, 0.025):
            assert t_quantile(p, dof) == float(stats.t.ppf(p, dof)), (p, dof)


def test_chi2_quantiles_are_scipy_stats_to_the_bit():
    for dof in (1, 2, 3, 5, 8, 13, 40):
        p = [0.975, 0.025, 0.5, 0.9]
        assert np.array_equal(chi2_quantile(p, dof), stats.chi2.ppf(p, dof)), dof
    for dof in (0, -1):            # scipy.stats: no such distribution, NaN
        assert np.isnan(chi2_quantile([0.975, 0.025], dof)).all()
        assert np.isnan(stats.chi2.ppf([0.975, 0.025], dof)).all()


def test_the_shell_identification_does_not_import_scipy_stats():
    code = ("import sys, roboball.identify.shell.hydro, roboball.identify.shell.regress, roboball.pipeline.hydro;"
            "print('scipy.stats' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
