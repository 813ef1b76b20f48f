"""GP regression: agreement with scikit-learn, incremental updates, ML-II fitting and its gradient."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

from ksbo_mav.errors import InputError
from ksbo_mav.gp import AdditiveKernel, GaussianProcess, cholesky_append, jitter_cholesky, log_marginal_likelihood

D = 9


def _toy(n, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.random((n, D))
    y = np.sin(4 * X[:, 0]) * X[:, 1] + np.cos(3 * X[:, 2] + X[:, 3]) + 0.05 * rng.standard_normal(n) + 3.0
    return X, y


@pytest.mark.parametrize("normalize_y", [True, False])
def test_order_D_gp_matches_sklearn(normalize_y):
    X, y = _toy(30)
    Xc = np.random.default_rng(9).random((50, D))
    ls = np.linspace(0.3, 1.2, D)
    noise, var = 1e-3, 1.7
    gp = GaussianProcess(AdditiveKernel(D, (D,), ls, order_variances=[var]), noise=noise, normalize_y=normalize_y)
    mu, sd = gp.fit(X, y).predict(Xc, return_std=True)
    sk_kernel = ConstantKernel(var, "fixed") * RBF(ls, "fixed")
    sk = GaussianProcessRegressor(sk_kernel, alpha=noise, optimizer=None, normalize_y=normalize_y).fit(X, y)
    mu_s, sd_s = sk.predict(Xc, return_std=True)
    np.testing.assert_allclose(mu, mu_s, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(sd, sd_s, rtol=1e-6, atol=1e-8)
    # the same with the noise as a WhiteKernel: sklearn's std then includes the noise, ours is latent
    sk_w = GaussianProcessRegressor(sk_kernel + WhiteKernel(noise, "fixed"), alpha=0.0, optimizer=None,
                                    normalize_y=normalize_y).fit(X, y)
    mu_w, sd_w = sk_w.predict(Xc, return_std=True)
    scale = y.std() if normalize_y else 1.0
    np.testing.assert_allclose(mu, mu_w, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(sd**2 + noise * scale**2, sd_w**2, rtol=1e-6)
    # and the log marginal likelihood
    np.testing.assert_allclose(gp.log_marginal_likelihood_value_, sk.log_marginal_likelihood_value_, rtol=1e-8)


def test_add_observation_equals_refit():
    X, y = _toy(20)
    k = AdditiveKernel(D, (2, 3, 4), 0.3)
    gp = GaussianProcess(k, noise=1e-4).fit(X[:12], y[:12])
    for i in range(12, 20):
        gp.add_observation(X[i], y[i])
    ref = GaussianProcess(k, noise=1e-4).fit(X, y)
    Xc = np.random.default_rng(1).random((40, D))
    m1, s1 = gp.predict(Xc, return_std=True)
    m2, s2 = ref.predict(Xc, return_std=True)
    np.testing.assert_allclose(gp.L_, ref.L_, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(m1, m2, rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(s1, s2, rtol=1e-8, atol=1e-10)
    assert gp.X_train_.shape == (20, D) and gp.y_std_ == pytest.approx(ref.y_std_)


def test_add_duplicate_point_falls_back_to_refactorisation():
    X, y = _toy(6)
    gp = GaussianProcess(AdditiveKernel(D, (1,), 0.3), noise=1e-12, normalize_y=False).fit(X, y)
    gp.add_observation(X[0], y[0] + 0.01)  # repeated input, pivot ~0 -> full refactorisation with jitter
    assert gp.L_.shape == (7, 7) and np.all(np.isfinite(gp.predict(X)))


def test_posterior_interpolates_and_std_is_latent():
    X, y = _toy(15)
    gp = GaussianProcess(AdditiveKernel(D, (1, 2), 0.4), noise=1e-8).fit(X, y)
    mu, sd = gp.predict(X, return_std=True)
    np.testing.assert_allclose(mu, y, atol=1e-4)
    assert np.all(sd < 1e-3)
    far_mu, far_sd = gp.predict(np.full((1, D), 0.5) + 10.0, return_std=True)  # prior far away
    np.testing.assert_allclose(far_sd, y.std(), rtol=1e-6)
    np.testing.assert_allclose(far_mu, y.mean(), rtol=1e-6)


def test_predict_many_candidates_shapes():
    X, y = _toy(10)
    gp = GaussianProcess(AdditiveKernel(D, (2, 3, 4), 0.2)).fit(X, y)
    Xc = np.random.default_rng(0).random((4096, D))
    mu, sd = gp.predict(Xc, return_std=True)
    assert mu.shape == (4096,) and sd.shape == (4096,) and np.all(sd >= 0)
    assert gp.predict(Xc[0]).shape == (1,)


def test_lml_gradient_matches_finite_differences():
    X, y = _toy(12)
    y = (y - y.mean()) / y.std()
    k = AdditiveKernel(D, (1, 3), np.linspace(0.2, 0.8, D), order_variances=[0.4, 1.5])
    noise = 0.02
    _, g = log_marginal_likelihood(k, X, y, noise, eval_gradient=True)
    th, h = np.append(k.theta, np.log(noise)), 1e-6

    def f(t):
        return log_marginal_likelihood(k.with_theta(t[:-1]), X, y, float(np.exp(t[-1])))[0]

    fd = np.array([(f(th + h * e) - f(th - h * e)) / (2 * h) for e in np.eye(th.size)])
    np.testing.assert_allclose(g, fd, rtol=1e-5, atol=1e-6)


def test_ml2_fit_improves_likelihood_and_respects_bounds():
    X, y = _toy(30, seed=4)
    k = AdditiveKernel(D, (1, 2), 2.0, lengthscale_bounds=(0.05, 5.0))
    fixed = GaussianProcess(k, noise=0.5).fit(X, y)
    fitted = GaussianProcess(k, noise=0.5, optimize=True, n_restarts=2, seed=0).fit(X, y)
    assert fitted.log_marginal_likelihood_value_ > fixed.log_marginal_likelihood_value_ + 1.0
    th, b = fitted.kernel_.theta, fitted.kernel_.theta_bounds
    assert np.all(th >= b[:, 0] - 1e-9) and np.all(th <= b[:, 1] + 1e-9)
    assert 1e-6 <= fitted.noise_ <= 1.0
    assert fitted.kernel.lengthscales == 2.0  # the constructor argument is not modified
    # a tight prior pins the lengthscale near its median
    pinned = GaussianProcess(k, noise=0.5, optimize=True, n_restarts=0, seed=0,
                             lengthscale_prior=(0.7, 1e-3)).fit(X, y)
    assert pinned.kernel_.lengthscales_[0] == pytest.approx(0.7, rel=1e-2)


def test_jitter_cholesky_and_append():
    A = np.ones((3, 3))  # singular
    L, j = jitter_cholesky(A)
    assert j > 0 and np.allclose(L @ L.T, A + j * np.eye(3))
    rng = np.random.default_rng(0)
    B = rng.random((5, 5))
    S = B @ B.T + np.eye(5)
    L4 = np.linalg.cholesky(S[:4, :4])
    np.testing.assert_allclose(cholesky_append(L4, S[:4, 4], S[4, 4]), np.linalg.cholesky(S), rtol=1e-12)
    assert cholesky_append(L4, S[:4, 0], S[0, 0]) is None  # duplicate column -> zero pivot


def test_bad_input():
    gp = GaussianProcess(AdditiveKernel(D, (1,)))
    with pytest.raises(InputError, match="not fitted"):
        gp.predict(np.zeros((1, D)))
    X, y = _toy(5)
    with pytest.raises(InputError, match="finite"):
        gp.fit(X, np.where(np.arange(5) == 2, np.nan, y))
    with pytest.raises(InputError, match="rows"):
        gp.fit(X, y[:4])
    with pytest.raises(InputError, match="shape"):
        gp.fit(X[:, :3], y)
    with pytest.raises(InputError, match="noise"):
        GaussianProcess(AdditiveKernel(D, (1,)), noise=0.0).fit(X, y)
