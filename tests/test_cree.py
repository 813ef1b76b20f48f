"""C_ree (Algorithm 1): exact identity, Woodbury form, convergence in c, order selection on known structure."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import qmc

from ksbo_mav.errors import InputError
from ksbo_mav.select import cree_exact, cree_nystrom, order_kernel_matrices, select_orders

D, L = 9, 36


def _pairs(X):
    """Sum of smooth 2-D interactions on dims 0..5; dims 6..8 do not matter."""
    return (np.sin(np.pi * X[:, 0]) * np.sin(np.pi * X[:, 1]) + 4 * (X[:, 2] - 0.5) * (X[:, 3] - 0.5)
            + np.exp(-((X[:, 4] - 0.5) ** 2 + (X[:, 5] - 0.5) ** 2) / 0.2))


@pytest.fixture(scope="module")
def prior():
    X = qmc.LatinHypercube(d=D, seed=0).random(L)
    y = _pairs(X)
    return X, (y - y.mean()) / y.std()


@pytest.mark.parametrize("mu", [1e-3, 0.1, 3.0])
def test_full_columns_full_rank_equals_exact(prior, mu):
    X, y = prior
    Ks = order_kernel_matrices(X, range(1, D + 1), 0.2)
    perm = np.random.default_rng(1).permutation(L)[None, :]  # any order of all l columns
    alg1 = cree_nystrom(Ks, y, columns=L, rank=L, mu=mu, indices=perm)[:, 0]
    exact = cree_exact(Ks, y, mu)
    direct = np.array([mu / L * y @ np.linalg.solve(K + mu * np.eye(L), y) for K in Ks])
    np.testing.assert_allclose(exact, direct, rtol=1e-10)
    np.testing.assert_allclose(alg1, exact, rtol=1e-8)


def test_algorithm1_equals_woodbury_form_with_rank_k_nystrom(prior):
    X, y = prior
    K = order_kernel_matrices(X, [3], 0.3)[0]
    mu, c, k = 0.05, 20, 12
    idx = np.random.default_rng(2).permutation(L)[:c]
    val = cree_nystrom(K, y, columns=c, rank=k, mu=mu, indices=idx[None])[0]
    s, U = np.linalg.eigh(K[np.ix_(idx, idx)])
    s, U = s[::-1][:k], U[:, ::-1][:, :k]
    Kt = K[:, idx] @ U @ np.diag(1 / s) @ U.T @ K[idx, :]  # C W_k^+ C^T
    np.testing.assert_allclose(val, mu / L * y @ np.linalg.solve(Kt + mu * np.eye(L), y), rtol=1e-8)
    assert 0 < val <= y @ y / L


def test_nystrom_converges_to_exact_as_c_grows(prior):
    X, y = prior
    K = order_kernel_matrices(X, [2], 0.25)[0]
    exact = cree_exact(K, y, 0.1)
    err = [np.mean(np.abs(cree_nystrom(K, y, columns=c, mu=0.1, trials=200, seed=3) - exact)) / exact
           for c in (8, 16, 24, 32, 36)]
    assert all(b < a for a, b in zip(err, err[1:])), err
    assert err[-1] < 1e-8 and err[0] > 0.05


def test_index_sets_order_does_not_matter(prior):
    X, y = prior
    K = order_kernel_matrices(X, [4], 0.2)[0]
    idx = np.array([[3, 17, 5, 30, 11, 0, 22], [0, 3, 5, 11, 17, 22, 30]])
    v = cree_nystrom(K, y, columns=7, mu=0.2, indices=idx)
    assert v[0] == pytest.approx(v[1], rel=1e-10)


def test_select_orders_prefers_low_order_on_sum_of_pairs():
    X = qmc.LatinHypercube(d=D, seed=0).random(L)
    y = _pairs(X) * 50 + 7  # scale and offset must not matter (y is standardised)
    sel = select_orders(X, y, trials=300, seed=0)
    assert sel.columns == 29 and sel.rank == 29 and len(sel.orders) == 3
    assert sel.mean[2] < sel.mean[9] and min(sel.orders) <= 3 and 9 not in sel.orders
    assert sel.ranking[: len(sel.orders)] == sel.orders
    assert all(sel.mean[a] <= sel.mean[b] for a, b in zip(sel.ranking, sel.ranking[1:]))
    freq = np.array(list(sel.top_frequency.values()))
    assert np.all((0 <= freq) & (freq <= 1)) and freq.sum() == pytest.approx(3)  # 3 orders in every trial's top 3
    assert sel.values.shape == (9, 300) and all(sel.std[r] >= 0 for r in range(1, 10))
    same = select_orders(X, _pairs(X), trials=300, seed=0)
    assert same.mean == pytest.approx(sel.mean)
    d = sel.to_dict()
    assert d["orders"] == list(sel.orders) and set(d["cree"]) == {str(r) for r in range(1, 10)}


def test_select_orders_exact_when_c_equals_l(prior):
    X, y = prior
    sel = select_orders(X, y, trials=5, columns=L, seed=0)
    for r in range(1, 10):
        assert sel.mean[r] == pytest.approx(sel.exact[r], rel=1e-8)
        assert sel.std[r] == pytest.approx(0, abs=1e-9)


@pytest.mark.parametrize(
    "kwargs, msg",
    [
        (dict(columns=0), "columns"),
        (dict(columns=37), "columns"),
        (dict(columns=10, rank=11), "rank"),
        (dict(mu=0.0), "mu"),
        (dict(orders=[0, 1]), "orders"),
        (dict(orders=[10]), "orders"),
        (dict(top=10), "top"),
        (dict(trials=0), "trials"),
    ],
)
def test_select_orders_bad_arguments(prior, kwargs, msg):
    X, y = prior
    with pytest.raises(InputError, match=msg):
        select_orders(X, y, **kwargs)


def test_bad_data(prior):
    X, y = prior
    with pytest.raises(InputError, match="finite"):
        select_orders(X, np.where(np.arange(L) == 0, np.nan, y))
    with pytest.raises(InputError, match="equal"):
        select_orders(X, np.ones(L))
    with pytest.raises(InputError, match="shape"):
        cree_exact(np.eye(3), np.ones(4), 0.1)
