"""The stopping rule in a campaign against `ksbo-mav sim` (the JSBSim copter as ArduCopter, own process, loopback
UDP, lockstep): the search stops once the next flight cannot pay, the console and the report say why in metres
and how many flights it saved, the confirmation is flown, the minimum holds; --no-early-stop flies the budget."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from mav_tune_helpers import sim_and_endpoint

from ksbo_mav.cli import main

pytestmark = [pytest.mark.network, pytest.mark.timeout(400)]


def _kinds(d) -> list[str]:
    return [json.loads(line)["kind"] for line in (d / "journal.jsonl").read_text().splitlines()]


def _tune(d, port: int, *extra: str) -> int:
    return main(["tune", str(d), "--udp", f"127.0.0.1:{port}", "--n-prior", "4", "--end", "hold",
                 "--no-onboard-guard", "--validation", "off", *extra])


def _profile(tmp_path: Path) -> str:
    """The shipped ArduCopter profile with a stopping threshold far above any gain (1000 x the noise): every check
    is below it, so only the minimum holds the search."""
    text = (Path(__file__).parents[1] / "params" / "ardupilot-copter.toml").read_text()
    assert "\nstop_patience = 1\n" in text
    path = tmp_path / "copter-stop-at-once.toml"
    path.write_text(text.replace("\nstop_patience = 1\n", "\nstop_patience = 1\nstop_ratio = 1000.0\n"))
    return str(path)


@pytest.mark.slow  # default run: the default campaign's early stop: test_sitl_ardupilot (one pack), test_cli_demo
def test_the_search_stops_says_why_and_confirms(tmp_path, capsys):
    d = tmp_path / "c"
    with sim_and_endpoint("--vehicle", "copter3d", "--personality", "ardupilot") as (_sim, ep):
        rc = _tune(d, ep.port, "--profile", _profile(tmp_path), "--budget", "8", "--min-trials", "3")
    out = capsys.readouterr()
    assert rc == 0, out.err
    kinds = _kinds(d)
    assert kinds.count("opt") == 3 and kinds.count("confirm") == 1  # the minimum, then the confirmation
    assert kinds.index("confirm") > max(i for i, k in enumerate(kinds) if k == "opt")
    said = re.search(r"search stopped after 3 of 8 optimiser trials: the next flight is expected to gain "
                     r"(\d+\.\d{3}) m; re-flight noise (\d+\.\d{3}) m \(the model's\) \(threshold 1000 x the noise\); "
                     r"5 flight\(s\) of the budget saved", " ".join(out.err.split()) + " " + " ".join(out.out.split()))
    assert said, out.err
    result = json.loads((d / "result.json").read_text())
    end = result["search_end"]
    assert end["stopped"] and end["after"] == 3 and end["saved"] == 5 and end["budget"] == 8
    assert [c["after"] for c in end["checks"]] == [1, 2, 3]
    # The metres are P's units times the baseline's RMS / (1 - P): 0.02 of P is 4 % of the baseline's lap RMS.
    assert float(said.group(2)) == pytest.approx(0.02 * end["m_per_P"], abs=6e-4)
    assert end["m_per_P"] == pytest.approx(2 * result["baseline"]["rms_m"], rel=1e-6)
    page = (d / "report" / "index.html").read_text()
    assert "Search ended" in page and "search stopped after 3 of 8 optimiser trials" in page
    assert _replayed_stop(d) == 3  # what --resume does: the journal through the optimiser stops at the same trial


def _replayed_stop(d: Path) -> int:
    """The journalled trials answered through the optimiser again, as a resumed campaign does (nothing flown):
    where its stopping rule stops now."""
    import numpy as np
    from threadpoolctl import threadpool_limits

    from ksbo_mav import optimize
    from ksbo_mav.campaign.config import CampaignConfig, optimizer_options, prior_kind, settle, stop_options
    from ksbo_mav.campaign.journal import Journal
    from ksbo_mav.campaign.layout import CampaignDir
    from ksbo_mav.campaign.replay import JournalReplay
    from ksbo_mav.profiles import load_profile

    saved = json.loads((d / "campaign.json").read_text())
    cfg = CampaignConfig(**saved["config"])
    profile = load_profile(cfg.profile or saved["profile"])
    cfg, _ = settle(cfg, profile, saved)
    done = Journal(CampaignDir.at(d).journal).of("opt")
    prior = json.loads((d / "prior.json").read_text())

    def fly(x):
        raise AssertionError("the replay asked for a flight the journal does not hold")

    x0 = np.array(saved["x0"])
    with threadpool_limits(1):
        r = optimize(JournalReplay(done, fly), x0, np.array(saved["bounds"]), prior=(np.array(prior["X"]),
                     np.array(prior["y"])), budget=cfg.budget, method=cfg.method, seed=cfg.seed, p_min=0.0,
                     **{**optimizer_options(prior_kind(cfg, profile), cfg.options, cfg.method, profile),
                        **stop_options(cfg, profile)})
    return r.info["stop"]["after"]


@pytest.mark.slow
def test_no_early_stop_flies_the_whole_budget(tmp_path, capsys):
    d = tmp_path / "c"
    with sim_and_endpoint("--vehicle", "copter3d", "--personality", "ardupilot") as (_sim, ep):
        rc = _tune(d, ep.port, "--profile", _profile(tmp_path), "--budget", "4", "--min-trials", "2",
                   "--no-early-stop")
    out = capsys.readouterr()
    assert rc == 0, out.err
    kinds = _kinds(d)
    assert kinds.count("opt") == 4 and kinds.count("confirm") == 1
    assert "search stopped" not in out.err + out.out
    result = json.loads((d / "result.json").read_text())
    assert result["search_end"] is None
    assert "the whole budget flown (early stop off: --no-early-stop)" in (d / "report" / "index.html").read_text()
