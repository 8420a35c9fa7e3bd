"""aerosid.Gtls: the on-board recursive PCA-GTLS estimator on seeded data."""

import numpy as np
import pytest

import aerosid


def errors_in_variables(seed, n=4000, sigma=0.05):
    """z = 0.3 + 1.5 x1 − 0.7 x2, x1 and x2 measured with noise σ, z with noise σ (seeded)."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 2))
    z = 0.3 + x @ np.array([1.5, -0.7])
    rows = np.column_stack([np.ones(n), x + sigma * rng.normal(size=(n, 2)), z + sigma * rng.normal(size=n)])
    return rows, np.array([0.3, 1.5, -0.7])


def test_estimates_within_four_sigma_of_the_truth():
    rows, truth = errors_in_variables(seed=7)
    g = aerosid.Gtls(3, n_exact=1, w_t=np.eye(3) * 0.05**2)
    assert g.update_many(rows) == len(rows)
    # Both noisy regressors excited (k counts the directions of the noisy block, eq. 21).
    assert g.excited == 2
    assert np.all(np.isfinite(g.sigma)) and np.all(g.sigma > 0)
    # Four σ: a 1-in-16 000 event per parameter for a correct σ (eq. 17); the σ are ~1e-3 here.
    assert np.all(np.abs(g.theta - truth) < 4 * g.sigma), (g.theta, g.sigma)
    assert g.covariance.shape == (3, 3)
    assert g.health["updates"] == len(rows)


def test_update_many_is_update_row_by_row():
    rows, _ = errors_in_variables(seed=3, n=500)
    a = aerosid.Gtls(3, n_exact=1)
    b = aerosid.Gtls(3, n_exact=1)
    a.update_many(rows)
    for r in rows:
        b.update(r)
    assert np.array_equal(a.theta, b.theta)


def test_a_bad_sample_is_refused_and_leaves_the_state():
    rows, _ = errors_in_variables(seed=5, n=200)
    g = aerosid.Gtls(3, n_exact=1)
    g.update_many(rows)
    before = g.theta.copy()
    assert g.update(np.array([1.0, np.nan, 0.0, 0.0])) is False
    assert g.rejected == 1
    assert np.array_equal(g.theta, before)


def test_too_few_samples_give_no_sigma():
    g = aerosid.Gtls(2)
    assert np.all(np.isnan(g.sigma))
    assert g.covariance is None


def test_dimensions_and_settings_are_checked():
    with pytest.raises(aerosid.AerosidError, match="not built in"):
        aerosid.Gtls(9)
    with pytest.raises(aerosid.AerosidError, match="w_t has shape"):
        aerosid.Gtls(3, n_exact=1, w_t=np.eye(4))
    with pytest.raises(aerosid.AerosidError, match="positive definite"):
        aerosid.Gtls(2, w_t=-np.eye(3))
    g = aerosid.Gtls(2)
    with pytest.raises(aerosid.AerosidError, match="needs 3"):
        g.update(np.zeros(2))
