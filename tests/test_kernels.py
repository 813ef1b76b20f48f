"""Additive kernels: Newton–Girard vs brute-force subset sums, structure options, gradients."""

from __future__ import annotations

import itertools
from math import comb

import numpy as np
import pytest

from ksbo_mav.errors import InputError
from ksbo_mav.gp import AdditiveKernel, elementary_symmetric

D = 9


def _base(X1, X2, ls):
    """(n1, n2, D) per-dimension SE values."""
    return np.exp(-0.5 * ((X1[:, None, :] - X2[None, :, :]) / ls) ** 2)


def _brute(z, r, dims=None):
    dims = range(z.shape[-1]) if dims is None else dims
    out = np.zeros(z.shape[:2])
    for S in itertools.combinations(dims, r):
        out += np.prod(z[:, :, list(S)], axis=2)
    return out


@pytest.fixture
def data():
    rng = np.random.default_rng(1)
    return rng.random((25, D)), rng.random((17, D)), rng.uniform(0.1, 0.7, D)


@pytest.mark.parametrize("method", ["newton-girard", "recursive"])
def test_order_r_equals_bruteforce_subset_sum(data, method):
    X1, X2, ls = data
    z = _base(X1, X2, ls)
    for r in range(1, D + 1):
        bf = _brute(z, r)
        K = AdditiveKernel(D, (r,), ls, order_variances=[1.0], normalize=False, method=method)(X1, X2)
        # relative to the matrix scale (Newton–Girard's error is absolute, see ksbo_mav.gp.symmetric)
        assert np.abs(K - bf).max() <= 1e-10 * np.abs(bf).max(), r
    if method == "recursive":  # the summation recurrence is accurate entry by entry
        for r in range(1, D + 1):
            K = AdditiveKernel(D, (r,), ls, order_variances=[1.0], normalize=False, method=method)(X1, X2)
            np.testing.assert_allclose(K, _brute(z, r), rtol=1e-12)


def test_elementary_symmetric_functions_agree():
    z = np.random.default_rng(0).random((D, 4, 3))
    a = elementary_symmetric(z, D, "newton-girard")
    b = elementary_symmetric(z, D, "recursive")
    np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(b[D], np.prod(z, axis=0), rtol=1e-12)
    with pytest.raises(ValueError):
        elementary_symmetric(z, 2, "bogus")  # type: ignore[arg-type]


def test_combined_orders_variances_and_normalisation(data):
    X1, X2, ls = data
    z = _base(X1, X2, ls)
    var = {2: 0.7, 3: 1.9, 4: 0.4}
    K = AdditiveKernel(D, (2, 3, 4), ls, order_variances=var)(X1, X2)
    expect = sum(v * _brute(z, r) / comb(D, r) for r, v in var.items())
    np.testing.assert_allclose(K, expect, rtol=1e-10, atol=1e-14)
    k = AdditiveKernel(D, (2, 3, 4), ls, order_variances=var)
    np.testing.assert_allclose(k.diag(X1), sum(var.values()))
    np.testing.assert_allclose(np.diag(k(X1)), k.diag(X1), rtol=1e-12)
    # default variances: each term 1/n_terms, so k(x, x) = 1
    np.testing.assert_allclose(AdditiveKernel(D, (2, 3, 4), ls).diag(X1), 1.0)
    kn = AdditiveKernel(D, (3,), ls, normalize=False, order_variances=[1.0])
    np.testing.assert_allclose(kn.diag(X1[:2]), comb(D, 3))


def test_order_D_is_product_se(data):
    X1, X2, ls = data
    K = AdditiveKernel(D, (D,), ls)(X1, X2)
    prod = np.exp(-0.5 * (((X1[:, None, :] - X2[None, :, :]) / ls) ** 2).sum(-1))
    np.testing.assert_allclose(K, prod, rtol=1e-9, atol=1e-15)


def test_active_dims_and_dropped_dimensions(data):
    X1, X2, ls = data
    z = _base(X1, X2, ls)
    act = [0, 2, 3, 7]
    dropped = [1, 4, 5, 6, 8]
    # dropped dims go to an extra order-1 term
    k = AdditiveKernel(D, (2,), ls, active_dims=act, order_variances=[2.0], inactive_variance=0.5)
    assert k.dropped_dims_ == tuple(dropped)
    expect = 2.0 * _brute(z, 2, act) / comb(4, 2) + 0.5 * _brute(z, 1, dropped) / len(dropped)
    np.testing.assert_allclose(k(X1, X2), expect, rtol=1e-10)
    # ... or are ignored
    k0 = AdditiveKernel(D, (2,), ls, active_dims=act, order_variances=[2.0], inactive_in_order1=False)
    np.testing.assert_allclose(k0(X1, X2), 2.0 * _brute(z, 2, act) / comb(4, 2), rtol=1e-10)
    Xm = X1.copy()
    Xm[:, dropped] = np.random.default_rng(5).random((X1.shape[0], len(dropped)))
    np.testing.assert_allclose(k0(Xm, X2), k0(X1, X2), rtol=1e-12)
    # order 1 present: it absorbs the dropped dims
    k1 = AdditiveKernel(D, (1, 2), ls, active_dims={1: [0], 2: [0, 2, 3, 7]}, order_variances=[1.0, 1.0])
    assert len(k1.terms_) == 2 and k1.terms_[0].dims == (0, 1, 4, 5, 6, 8)
    # per-order dimension sets
    k2 = AdditiveKernel(D, (2, 3), ls, active_dims={2: [0, 1], 3: [2, 3, 4, 5]}, inactive_in_order1=False,
                        order_variances=[1.0, 1.0])
    np.testing.assert_allclose(k2(X1, X2), _brute(z, 2, [0, 1]) + _brute(z, 3, [2, 3, 4, 5]) / 4, rtol=1e-10)


@pytest.mark.parametrize("shared", [True, False])
def test_gradient_matches_finite_differences(shared):
    rng = np.random.default_rng(3)
    X = rng.random((8, D))
    ls = 0.3 if shared else rng.uniform(0.15, 0.6, D)
    k = AdditiveKernel(D, (1, 2, 4), ls, order_variances=[0.5, 1.3, 0.8], active_dims={1: [0, 1], 2: [0, 1, 2, 3],
                                                                                       4: [3, 4, 5, 6, 7]})
    K, dK = k.value_and_gradient(X)
    np.testing.assert_allclose(K, k(X), rtol=1e-12)
    th, h = k.theta, 1e-6
    assert dK.shape == (th.size, 8, 8)
    for j in range(th.size):
        e = np.zeros_like(th)
        e[j] = h
        fd = (k.with_theta(th + e)(X) - k.with_theta(th - e)(X)) / (2 * h)
        np.testing.assert_allclose(dK[j], fd, atol=1e-8)


def test_with_theta_roundtrip():
    k = AdditiveKernel(D, (2, 3), np.linspace(0.1, 0.9, D), active_dims=[0, 1, 2], order_variances=[0.3, 2.0])
    k2 = k.with_theta(k.theta)
    np.testing.assert_allclose(k2.theta, k.theta)
    assert k2.theta_bounds.shape == (k.theta.size, 2)


def test_kernel_matrix_is_positive_semidefinite():
    X = np.random.default_rng(7).random((40, D))
    for orders in [(1,), (2, 3, 4), (9,), (1, 9)]:
        ev = np.linalg.eigvalsh(AdditiveKernel(D, orders, 0.25)(X))
        assert ev.min() > -1e-10 * ev.max()


@pytest.mark.parametrize(
    "kwargs, msg",
    [
        (dict(dim=0), "dim"),
        (dict(dim=D, orders=()), "orders"),
        (dict(dim=D, orders=(2.5,)), "orders"),
        (dict(dim=D, orders=(10,)), "order 10"),
        (dict(dim=D, orders=(3,), active_dims=[0, 1]), "order 3"),
        (dict(dim=D, lengthscales=-1.0), "lengthscales"),
        (dict(dim=D, lengthscales=np.ones(3)), "lengthscales"),
        (dict(dim=D, orders=(1, 2), order_variances=[1.0]), "order_variances"),
        (dict(dim=D, orders=(1, 2), order_variances={5: 1.0}), "order_variances"),
        (dict(dim=D, active_dims=[0, 9]), "active_dims"),
        (dict(dim=D, orders=(1, 2), active_dims={1: [0]}), "active_dims"),
        (dict(dim=D, method="fft"), "method"),
    ],
)
def test_bad_arguments_raise_input_error(kwargs, msg):
    with pytest.raises(InputError, match=msg):
        AdditiveKernel(**kwargs)


def test_bad_points_raise():
    k = AdditiveKernel(D, (2,))
    with pytest.raises(InputError, match="shape"):
        k(np.zeros((3, 4)))
