"""The optimiser's options: a declared set (at most 35), each with a constraint checked in one place whose error
names the option, the value and what it accepts; the documentation page and the `tune --option` listing carry one
line per option; the method presets only set fields of the typed configs."""

from __future__ import annotations

from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest

import ksbo_mav
from ksbo_mav.cli import main
from ksbo_mav.errors import InputError
from ksbo_mav.opt.constraints import Choice, Interval, Orders
from ksbo_mav.opt.options import METHOD_DEFAULTS, OPTIONS, Options, options_for, options_markdown

DOC = Path(__file__).resolve().parents[1] / "docs" / "options.md"


def _bad_values(name: str) -> list[object]:
    """Values outside the option's declared constraint: the wrong kind, and the wrong range or choice."""
    c = OPTIONS[name][0]
    bad: list[object] = ["abc", [1.0, "x"]]
    if isinstance(c, Interval):
        bad += [float("nan")] + ([c.low - 1] if c.low is not None else [])
        bad += [c.high + 1] if c.high is not None else []
        bad += [2.5] if c.integer else []
        bad += [] if c.none else [None]
    elif isinstance(c, Choice):
        bad += [1, "none-of-these"]
    elif isinstance(c, Orders):
        bad += [[0], [1, 1], [1.5], []]
    return bad


def test_there_are_at_most_36_options_each_a_field_of_the_typed_configs() -> None:
    assert len(OPTIONS) <= 36
    assert set(OPTIONS) <= {f.name for f in fields(Options)}
    for preset in METHOD_DEFAULTS.values():  # presets may set internal knobs too, but only real fields
        assert set(preset) <= {f.name for f in fields(Options)}


@pytest.mark.parametrize("name", sorted(OPTIONS))
def test_every_bad_value_of_every_option_is_one_line_naming_it(name: str) -> None:
    for value in _bad_values(name):
        with pytest.raises(InputError) as err:
            options_for("ksbo-adaptive", {name: value})
        msg = str(err.value)
        assert "\n" not in msg and msg.startswith(f"option {name}=") and OPTIONS[name][0].describe() in msg, msg


@pytest.mark.parametrize("name", sorted(OPTIONS))
def test_every_option_accepts_its_own_default(name: str) -> None:
    for method in METHOD_DEFAULTS:
        default = getattr(options_for(method), name)
        value = list(default) if isinstance(default, tuple) else default
        assert getattr(options_for(method, {name: value}), name) == default


def test_values_are_stored_in_the_fields_type() -> None:
    o = options_for("ksbo", {"orders": [1, 2], "expansion_iters": 4.0, "max_aborts": None, "beta": 3})
    assert (o.orders, o.expansion_iters, o.max_aborts, o.beta) == ((1, 2), 4, None, 3)
    assert isinstance(o.expansion_iters, int)


def test_an_unknown_option_lists_every_option_with_one_line_each() -> None:
    with pytest.raises(InputError) as err:
        options_for("ksbo", {"beta_min": 4.0})
    lines = str(err.value).splitlines()
    assert lines[0].startswith("unknown option(s) beta_min")
    assert [ln.split()[0] for ln in lines[1:]] == list(OPTIONS)


def test_internal_knobs_are_not_options() -> None:
    """A knob the presets or the code set (candidate refinement, trust-region growth) is refused by optimize."""
    with pytest.raises(InputError, match="unknown option"):
        ksbo_mav.optimize(lambda x: 0.5, np.array([0.5]), np.array([[0.0, 1.0]]), budget=2, tr_grow=3.0)


def test_tune_option_error_names_the_option_and_lists_them(tmp_path, capsys) -> None:
    rc = main(["tune", str(tmp_path / "c"), "--udp", "127.0.0.1:9", "--option", "beta=-2"])
    err = capsys.readouterr().err
    assert rc == 2 and "option beta=-2 is not allowed: beta must be a number in (0, inf)" in err
    rc = main(["tune", str(tmp_path / "c"), "--udp", "127.0.0.1:9", "--option", "nope=1"])
    err = capsys.readouterr().err
    assert rc == 2 and "unknown option(s) nope" in err and "  refly_stress " in err


def test_the_options_page_is_generated_from_the_declarations() -> None:
    """docs/options.md holds options_markdown() between its markers (regenerate: see the page's head)."""
    text = DOC.read_text()
    table = text.split("<!-- options:begin -->\n", 1)[1].split("\n<!-- options:end -->", 1)[0]
    assert table == options_markdown()
