"""The chi-square quantiles of :mod:`inmotion.estimation.chi2`, computed without scipy, against
``scipy.stats.chi2`` (the reference: cephes' ``igam`` / ``igami``) on a grid of degrees of
freedom and tail probabilities, and the run path's independence of ``scipy.special``
(issue 13: a command-line run's fixed cost)."""
import subprocess
import sys

import numpy as np
import pytest
from scipy.special import gammainc, gammaincc
from scipy.stats import chi2 as stats_chi2

from inmotion.estimation import chi2

#: tail probabilities: the deep tails, the gates' and FDI's rates, the NIS / NEES bands
TAILS = np.array([1e-300, 1e-100, 1e-20, 1e-12, 1e-9, 1e-6, 1e-3, 0.01, 0.025, 0.05, 0.1, 0.3,
                  0.5, 0.7, 0.9, 0.95, 0.975, 0.99, 0.999, 0.9999, 1 - 1e-6, 1 - 1e-9,
                  1 - 1e-12])
#: the gates' and the FDI's (1 .. 6 rows, 15 a bank), the NEES bands' (3 x runs), the NIS
#: summaries' (every scalar row of a drive: 1e4 .. 1e6 for hours at 10 Hz)
DOFS = [0.5, 1, 2, 3, 4, 5, 6, 7, 9, 15, 19, 20, 21, 30, 50, 150, 300, 1000, 1e4, 72000, 1e6]


@pytest.mark.parametrize("dof", DOFS)
def test_quantiles_are_scipy_stats_values_to_1e_11(dof):
    for ours, ref in ((chi2.ppf, stats_chi2.ppf), (chi2.isf, stats_chi2.isf)):
        got, want = ours(TAILS, dof), ref(TAILS, dof)
        pos = want > 0
        np.testing.assert_allclose(got[pos], want[pos], rtol=1e-11, atol=0)
        assert np.all(got[~pos] < 1e-290)          # underflow where scipy's is 0 too


@pytest.mark.parametrize("dof", [1, 3, 150, 1e4])
def test_the_quantile_puts_its_tail_where_it_was_asked(dof):
    """Independently of scipy's inverse: scipy's forward regularized gamma functions at our
    quantiles give back the probabilities asked for."""
    p = np.array([1e-9, 0.025, 0.5, 0.975, 1 - 1e-9])
    np.testing.assert_allclose(gammainc(dof / 2, chi2.ppf(p, dof) / 2), p, rtol=1e-10)
    np.testing.assert_allclose(gammaincc(dof / 2, chi2.isf(p, dof) / 2), p, rtol=1e-10)


def test_quantiles_take_scalars_and_arrays_and_refuse_what_scipy_refuses():
    for q in (0.01, 0.999):                  # scalars in, floats out, as scipy.stats gives
        assert isinstance(chi2.ppf(q, 3), float) and isinstance(chi2.threshold(q, 3), float)
    assert chi2.threshold(0.01, 3) == chi2.isf(0.01, 3)
    got = chi2.ppf([0.025, 0.975], 3 * 50)     # the reproductions' NEES band
    np.testing.assert_allclose(got, stats_chi2.ppf([0.025, 0.975], 150), rtol=1e-11)
    np.testing.assert_allclose(chi2.ppf(0.9, [1, 2, 3]), stats_chi2.ppf(0.9, [1, 2, 3]),
                               rtol=1e-11)
    assert chi2.ppf([[0.1], [0.9]], [1, 2]).shape == (2, 2)
    assert chi2.ppf(0.0, 3) == 0.0 and chi2.ppf(1.0, 3) == np.inf
    assert chi2.isf(0.0, 3) == np.inf and chi2.isf(1.0, 3) == 0.0
    bad = chi2.ppf([-0.1, 1.1, np.nan], 3)
    assert np.all(np.isnan(bad)) and np.all(np.isnan(stats_chi2.ppf([-0.1, 1.1, np.nan], 3)))
    for dof in (0, -1, np.nan, np.inf):
        assert np.isnan(chi2.ppf(0.5, dof)) and np.isnan(stats_chi2.ppf(0.5, dof))
    # beyond 1e7 degrees of freedom scipy computes them
    assert chi2.isf(0.5, 2e7) == float(stats_chi2.isf(0.5, 2e7))


def test_quantiles_and_the_nis_summary_do_not_import_scipy():
    code = ("import sys\nfrom inmotion.estimation import chi2\n"
            "chi2.ppf([0.025, 0.975], 150); chi2.threshold(1e-3, 3); chi2.nis_summary(7.0, 6, 3)\n"
            "print('scipy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "False"
