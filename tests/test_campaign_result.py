"""result.json of a finished campaign: written after the report plots, naming them, and written even when the plots
fail (a plotting problem never hides the tuning result); the temporary file is renamed into place."""

from __future__ import annotations

import json

from ksbo_mav.campaign.ending import write_result
from ksbo_mav.campaign.layout import FORMAT_VERSION, CampaignDir
from ksbo_mav.campaign.summary import CampaignSummary


def _summary(d: CampaignDir) -> CampaignSummary:
    return CampaignSummary(baseline={"P": 0.2, "values": {"POS_X_P": 0.15}},
                           best={"P_model": 0.8, "values": {"POS_X_P": 0.16}, "x": [0.16]},
                           accepted=False, on_vehicle={"POS_X_P": 0.15},
                           n_trials=0, n_unsafe=0, n_aborted=0, n_crashed=0, n_failed=0, method="ksbo-adaptive",
                           orders=None, wall_s=1.0, dir=str(d.root), ended="")


def _settings(d: CampaignDir) -> None:
    """The campaign.json of a one-gain campaign: what the report reads to name and scale the gains."""
    d.config.write_text(json.dumps({"format": FORMAT_VERSION, "config": {}, "profile": "sim-planar",
                                    "baseline": {"POS_X_P": 0.15}, "x0": [0.15], "bounds": [[0.05, 0.3]]}))


def test_result_names_the_plots_it_was_written_after(tmp_path):
    d = CampaignDir.at(tmp_path / "camp")
    d.root.mkdir()
    _settings(d)
    d.journal.write_text("")  # a campaign that journalled nothing: the convergence plot is drawn empty
    s = _summary(d)
    write_result(d, s, None, log=lambda line: None)
    doc = json.loads(d.result.read_text())
    assert doc["plots"] == s.plots and s.plots["safety"] == "none"
    assert (d.report / "convergence.png").stat().st_size > 0
    assert [p.name for p in d.root.iterdir() if p.name.startswith("result")] == ["result.json"]


def test_result_is_written_when_the_plots_fail(tmp_path):
    d = CampaignDir.at(tmp_path / "camp")
    d.root.mkdir()
    d.report.write_text("a file where the report directory should go")
    said: list[str] = []
    write_result(d, _summary(d), None, log=said.append)
    assert len(said) == 1 and said[0].startswith("report plots failed")
    doc = json.loads(d.result.read_text())
    assert doc["plots"] == {} and doc["best"]["P_model"] == 0.8
