"""`ksbo-mav prior` and `ksbo-mav select`: outputs, JSON keys, plot, and one-line errors on bad CSVs."""

from __future__ import annotations

import csv
import json
import subprocess
import sys

import numpy as np
import pytest
from scipy.stats import qmc

from ksbo_mav.cli import main
from ksbo_mav.profiles import load_profile
from ksbo_mav.select.prior_csv import read_prior_csv, write_prior_csv

PROFILE = load_profile("sim-planar")
NAMES = PROFILE.names


@pytest.fixture
def synthetic_csv(tmp_path):
    """36 points whose P depends on the first four gains only (two 2-D interactions)."""
    U = qmc.LatinHypercube(d=9, seed=0).random(36)
    P = 2 * U[:, 0] * U[:, 1] + 2 * U[:, 2] * U[:, 3]
    return write_prior_csv(tmp_path / "prior.csv", NAMES, PROFILE.from_unit(U), P)


def _write(path, rows):
    with open(path, "w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    return path


def test_prior_writes_csv_box_and_local(tmp_path, capsys):
    out = tmp_path / "box.csv"
    assert main(["prior", "--n", "10", "--seed", "1", "--out", str(out)]) == 0
    assert "unsafe" in capsys.readouterr().out
    header = out.read_text().splitlines()[0].split(",")
    assert header == NAMES + ["P"]
    X, P = read_prior_csv(out, NAMES)
    assert X.shape == (10, 9) and np.all(P <= 1) and np.all(P > -1.0001)
    U = PROFILE.to_unit(X)
    assert np.all((U >= 0) & (U <= 1))
    loc = tmp_path / "local.csv"
    assert main(["prior", "--n", "10", "--design", "local", "--radius", "0.05", "--out", str(loc), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["n"] == 10 and summary["design"] == "local"
    Xl, Pl = read_prior_csv(loc, NAMES)
    Ul, u0 = PROFILE.to_unit(Xl), PROFILE.to_unit(PROFILE.default)
    assert np.all(np.abs(Ul - u0) <= 0.05 + 1e-9)
    assert summary["n_unsafe"] == int(np.sum(Pl < 0))


def test_select_json_keys(synthetic_csv, capsys):
    assert main(["select", str(synthetic_csv), "--trials", "200", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ("orders", "cree", "cree_std", "dims"):
        assert key in out
    assert len(out["orders"]) == 3 and set(out["cree"]) == {str(r) for r in range(1, 10)}
    assert set(out["dims"]) == {str(r) for r in out["orders"]}
    for names in out["dims"].values():
        assert set(names) <= set(NAMES)
        assert set(NAMES[:4]) <= set(names)  # the four gains that matter are kept
    assert out["settings"] == {"columns": 29, "rank": 29, "mu": 0.1, "trials": 200, "top": 3}


def test_select_table_and_plot(synthetic_csv, tmp_path, capsys):
    png = tmp_path / "cree.png"
    args = ["select", str(synthetic_csv), "--trials", "50", "--top", "2", "--columns", "30", "--rank", "25",
            "--mu", "0.05", "--plot", str(png)]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "chosen orders" in text and "c=30, k=25, mu=0.05" in text
    assert sum(line.rstrip().endswith("*") for line in text.splitlines()) == 2
    assert png.stat().st_size > 5_000


@pytest.mark.parametrize(
    "rows, msg",
    [
        ([NAMES[:-1] + ["P"]] + [[1.0] * 9] * 12, "missing column(s) ATT_PIT_D"),
        ([NAMES] + [[1.0] * 9] * 12, "missing column(s) P"),
        ([NAMES + ["P"]] + [[0.1] * 10] * 5 + [[0.1] * 9 + ["abc"]] + [[0.1] * 10] * 6, "line 7, column P: 'abc'"),
        ([NAMES + ["P"]] + [[0.1] * 10] * 3 + [["nan"] + [0.1] * 9] + [[0.1] * 10] * 8, "not finite"),
        ([NAMES + ["P"]] + [[0.1] * 10] * 9, "9 data row(s) but 10 columns"),
        ([NAMES + ["P"]] + [[0.1] * 10] * 11 + [[0.1] * 8], "fields"),
        ([], "empty"),
    ],
)
def test_select_bad_csv_is_one_line_error(tmp_path, capsys, rows, msg):
    path = _write(tmp_path / "bad.csv", rows)
    assert main(["select", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and msg in err and len(err.strip().splitlines()) == 1


def test_select_bad_options(synthetic_csv, capsys):
    assert main(["select", str(synthetic_csv), "--columns", "40"]) == 2
    assert "--columns" in capsys.readouterr().err
    assert main(["select", str(synthetic_csv), "--columns", "10", "--rank", "12"]) == 2
    assert "rank" in capsys.readouterr().err


def test_select_missing_file_subprocess(tmp_path):
    r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "select", str(tmp_path / "nope.csv")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "no such file" in r.stderr and "Traceback" not in r.stderr


def test_read_prior_csv_roundtrip_with_bom_and_column_order(tmp_path):
    rng = np.random.default_rng(0)
    X, P = PROFILE.from_unit(rng.random((12, 9))), rng.standard_normal(12)
    src = write_prior_csv(tmp_path / "a.csv", NAMES, X, P)
    rows = list(csv.reader(src.open()))
    perm = [9, *range(8, -1, -1)]  # P first, gains reversed, plus an extra column
    text = "\ufeff" + "\n".join(",".join([r[i] for i in perm] + ["x"]) for r in rows) + "\n"
    (tmp_path / "b.csv").write_text(text, encoding="utf-8")
    X2, P2 = read_prior_csv(tmp_path / "b.csv", NAMES)
    np.testing.assert_array_equal(X2, X)
    np.testing.assert_array_equal(P2, P)
