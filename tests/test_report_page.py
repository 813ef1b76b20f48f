"""The campaign report page (report/index.html) from a real short campaign against the simulator process: a
well-formed, self-contained page (every image an embedded PNG), the verdict before the plots, every flown trial
in the table with the console's numbering, the box-edge note on the console and on the page, text escaped, and
`ksbo-mav report DIR` regenerating it."""

from __future__ import annotations

import base64
import contextlib
import io
import json
import re
import shutil
import xml.etree.ElementTree as ET
from dataclasses import replace
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from mav_tune_helpers import sim_and_endpoint

from ksbo_mav.cli import main

pytestmark = [pytest.mark.network, pytest.mark.timeout(240)]

PNG = b"\x89PNG\r\n\x1a\n"
VOID = {"meta", "img", "br", "hr", "link", "input"}


def _profile_without_the_optimum(src: Path, dst: Path) -> None:
    """sim-planar with POS_X_P's box ending at its default 0.15 (P keeps rising to about 0.4: the optimum lies
    outside) and every other gain held within 1 % of its default (so the campaign is about POS_X_P)."""

    def narrow(block: str) -> str:
        name = re.search(r'name = "(\w+)"', block).group(1)
        default = float(re.search(r"\ndefault = ([0-9.eE+-]+)", block).group(1))
        # 0.1500001: the vehicle stores 0.15 as float32 (0.15000000596), which must lie inside the box.
        lo, hi = (0.10, 0.1500001) if name == "POS_X_P" else (default * 0.99, default * 1.01) if default else (0, 1e-3)
        block = re.sub(r"\nmin = [0-9.eE+-]+", f"\nmin = {lo!r}", block)
        return re.sub(r"\nmax = [0-9.eE+-]+", f"\nmax = {hi!r}", block)

    head, *gains = src.read_text().split("[[gains]]")
    dst.write_text(head + "".join("[[gains]]" + narrow(g) for g in gains))


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """(campaign directory, console output) of `ksbo-mav tune` with a flown prior and two confirmations."""
    tmp = tmp_path_factory.mktemp("report")
    profile = tmp / "edge.toml"
    _profile_without_the_optimum(Path(__file__).parents[1] / "params" / "sim-planar.toml", profile)
    d = tmp / "camp"
    out, err = io.StringIO(), io.StringIO()  # summary on stdout, one line per trial on stderr
    with sim_and_endpoint() as (_, ep), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(["tune", str(d), "--udp", f"127.0.0.1:{ep.port}", "--profile", str(profile), "--budget", "4",
                   "--prior", "local", "--n-prior", "2", "--confirm", "2", "--end", "hold"])
    assert rc == 0, err.getvalue()
    return d, err.getvalue() + out.getvalue()


class _TagChecker(HTMLParser):
    """Every start tag closed by the matching end tag, in order; void elements written self-closed."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.stack: list[str] = []
        self.errors: list[str] = []
        self.imgs: list[dict[str, str]] = []
        self.text: list[str] = []

    def handle_starttag(self, tag, attrs):
        if tag in VOID:
            self.errors.append(f"<{tag}> not self-closed at {self.getpos()}")
        else:
            self.stack.append(tag)

    def handle_startendtag(self, tag, attrs):
        if tag not in VOID:
            self.errors.append(f"<{tag}/> is not a void element at {self.getpos()}")
        if tag == "img":
            self.imgs.append(dict(attrs))

    def handle_endtag(self, tag):
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"</{tag}> closes {self.stack[-1] if self.stack else 'nothing'} at {self.getpos()}")
        else:
            self.stack.pop()

    def handle_data(self, data):
        self.text.append(data)


def _page(d: Path) -> str:
    return (d / "report" / "index.html").read_text(encoding="utf-8")


def _journal(d: Path) -> list[dict]:
    return [json.loads(line) for line in (d / "journal.jsonl").read_text().splitlines()]


def test_page_is_well_formed_and_every_image_is_an_embedded_png(campaign):
    from matplotlib.image import imread

    d, console = campaign
    page = _page(d)
    checker = _TagChecker()
    checker.feed(page)
    checker.close()
    assert not checker.errors and not checker.stack, (checker.errors, checker.stack)
    ET.fromstring(page.split("\n", 1)[1])  # XHTML-compatible: parses as XML after the doctype line
    assert "http://" not in page.replace('xmlns="http://www.w3.org/1999/xhtml"', "") and "<script" not in page
    plots = {k: v for k, v in json.loads((d / "result.json").read_text())["plots"].items()
             if k != "page" and v != "none"}
    assert {"convergence", "gains", "trajectory"} <= set(plots)
    assert len(checker.imgs) == len(plots)
    for img in checker.imgs:
        prefix = "data:image/png;base64,"
        assert img["src"].startswith(prefix)
        raw = base64.b64decode(img["src"][len(prefix):], validate=True)
        assert raw.startswith(PNG)
        pixels = imread(io.BytesIO(raw), format="png")
        assert pixels.ndim == 3 and pixels.shape[0] > 200 and pixels.shape[1] > 400
    assert f"report: {d / 'report' / 'index.html'}" in console


def test_verdict_comes_first_and_the_table_numbers_every_trial_as_the_console(campaign):
    d, console = campaign
    page = _page(d)
    assert page.index("Verdict") < page.index("<img") < page.index("<h2>Trials")
    verdict = page[page.index("Verdict"):page.index("<img")]
    for words in ("Lap RMS", "Gains changed", "Flights", "unsafe (P &lt; 0) 0", "aborted by the monitor",
                  "crashed", "interrupted"):
        assert words in verdict
    table = page[page.index("<h2>Trials"):]
    rows = re.findall(r"<tr[^>]*><td>(\d+)</td><td class=\"l\">([^<]+)</td><td>([^<]+)</td>", table)
    journal = _journal(d)
    assert [int(n) for n, _, _ in rows] == [e["trial"] for e in journal]
    # The console printed each trial with the same number, the table's name for it, and P.
    for (n, role, _), e in zip(rows, journal):
        assert f"trial {e['trial']:3d} {role:<21} P {e['P']:+.4f}" in console
    kinds = [k for _, k, _ in rows]
    assert kinds[0] == "baseline" and kinds.count("prior") == 2 and kinds[-2:] == ["confirmation"] * 2
    assert [f"{e['P']:+.4f}" for e in journal] == [p for _, _, p in rows]


def test_box_edge_note_on_the_console_and_on_the_page(campaign):
    """The optimum lies past POS_X_P's upper bound: the recommendation ends there and both places say so."""
    d, console = campaign
    notes = [line.removeprefix("search box: ") for line in console.splitlines() if line.startswith("search box: ")]
    assert any(n.startswith("POS_X_P = 0.15 is at the upper bound 0.15 of the search box, which is the profile's "
                            "upper limit") for n in notes), console
    page = _page(d)
    import html

    for n in notes:
        assert html.escape(n) in page


def test_report_command_regenerates_the_page_and_refuses_a_non_campaign(campaign, tmp_path, capsys):
    d, _ = campaign
    copy = tmp_path / "copy"
    shutil.copytree(d, copy)
    shutil.rmtree(copy / "report")
    assert main(["report", str(copy)]) == 0
    out = capsys.readouterr().out
    assert f"report: {copy / 'report' / 'index.html'}" in out and "search box: POS_X_P" in out
    assert (copy / "report" / "index.html").stat().st_size > 10_000
    assert main(["report", str(tmp_path / "nothing")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no campaign" in err


def test_plots_drawn_from_the_same_flights_are_kept_and_the_report_command_draws_them_anew(campaign, tmp_path):
    from ksbo_mav.campaign.report.writer import write_report

    d, _ = campaign
    copy = tmp_path / "copy"
    shutil.copytree(d, copy)
    plot = copy / "report" / "gains.png"

    def drawn_at() -> int:
        return plot.stat().st_mtime_ns

    first = write_report(copy)  # the copy's plots.json names the plots drawn from the same flights: kept
    at = drawn_at()
    assert write_report(copy) == first and drawn_at() == at  # nothing new flown: the plots kept
    with open(copy / "journal.jsonl", "a") as f:  # a flight more (a line the reader skips still changes the file)
        f.write("\n")
    write_report(copy)
    assert drawn_at() > at  # drawn again
    at = drawn_at()
    assert main(["report", str(copy)]) == 0 and drawn_at() > at  # the command always draws


def test_text_on_the_page_is_escaped(campaign):
    from ksbo_mav.campaign.layout import CampaignDir
    from ksbo_mav.campaign.report.page import render
    from ksbo_mav.campaign.report.rows import read_campaign

    d, _ = campaign
    rec = read_campaign(CampaignDir.at(d), rms=False)
    evil = '<b onload="x">&'
    rec = replace(rec, settings={**rec.settings, "profile": evil})
    page = render(rec, None, [], {}, title=evil)
    assert evil not in page and "&lt;b onload=&quot;x&quot;&gt;&amp;" in page
    checker = _TagChecker()
    checker.feed(page)
    assert not checker.errors and not checker.stack


def test_plot_frames_follow_the_missions_task_states():
    """The plan view of the horizontal figure-8 is a map (east right, north up); the planar one is north / up."""
    from ksbo_mav.mav.mission import task_state
    from ksbo_mav.plotting import FRAMES

    ned = np.array([1.0, 2.0, -3.0, 0.0, 0.0, 0.0])  # north 1, east 2, up 3
    att = np.full(4, np.nan)
    s = task_state("figure8-ne", ned, att)
    (h, h_label), (v, v_label) = FRAMES["figure8-ne"]["plan"]
    assert (s[h], s[v]) == (2.0, 1.0) and h_label.startswith("east") and v_label.startswith("north")
    assert [s[c] for c, _ in FRAMES["figure8-ne"]["errors"]] == [1.0, 2.0, 3.0]
    s = task_state("figure8-xz", np.array([1.0, 0.0, -3.0, 0.0, 0.0, 0.0]), att)
    (h, h_label), (v, v_label) = FRAMES["figure8-xz"]["plan"]
    assert (s[h], s[v]) == (1.0, 3.0) and "north" in h_label and "up" in v_label


def _set_on_sim(sim, **params: float) -> None:
    """Set simulator parameters over a second connection (as a second ground station would)."""
    from ksbo_mav.mav.link import Endpoint
    from ksbo_mav.mav.vehicle import Vehicle

    other = Vehicle.connect(Endpoint("udpout", "127.0.0.1", sim.port), "sim-planar", sysid=250, compid=190)
    try:
        for name, value in params.items():
            other.params.set_verified(name, value, retries=8)
    finally:
        other.close()


def _verdict(page: str) -> str:
    return page[page.index("Verdict"):page.index("<h2>Plots")]


@pytest.mark.slow
def test_a_crashed_confirmation_is_counted_and_the_verdict_says_not_confirmed(tmp_path):
    """The vehicle really crashes as the confirmation's gains are written (SIM_CRASH_WRITES, set once the last
    optimiser trial is journalled): the page counts it as the console does and shows the safety plot."""
    from ksbo_mav.campaign import Campaign, CampaignConfig

    d = tmp_path / "c"
    roles: dict[int, str] = {}  # what the console called each trial
    with sim_and_endpoint() as (sim, ep):
        cfg = CampaignConfig(dir=str(d), budget=3, seed=1, prior="none", end="hold")

        def crash_next(event) -> None:
            roles[event.flight.meta["trial"]] = event.role
            if event.kind == "opt" and event.n_opt == cfg.budget:
                _set_on_sim(sim, SIM_CRASH_WRITES=1.0)

        summary = Campaign(cfg, ep, log=lambda s: None, progress=crash_next).run()
    assert summary.n_crashed == 1 and summary.plots["safety"] != "none"
    # The console's name of each trial is the report's (the first optimiser trial is "baseline" in both).
    from ksbo_mav.campaign.layout import CampaignDir
    from ksbo_mav.campaign.report.rows import read_campaign

    rows = read_campaign(CampaignDir.at(d), rms=False).rows
    assert roles == {r.trial: r.role for r in rows if r.trial in roles} and roles[0] == "baseline"
    verdict = _verdict(_page(d))
    assert "Not confirmed: confirmation trial" in verdict
    assert (f"unsafe (P &lt; 0) {summary.n_unsafe}, aborted by the monitor {summary.n_aborted}, crashed 1, "
            f"interrupted (not the gains) {summary.n_failed}") in verdict
    crashed = [e["trial"] for e in _journal(d) if e["outcome"] == "crash"]
    assert re.search(rf'<tr class="crash"><td>{crashed[0]}</td><td class="l">confirmation</td>', _page(d))


@pytest.mark.slow
def test_report_of_an_interrupted_campaign_shows_the_trials_so_far(tmp_path, capsys):
    """The pilot takes over during the baseline trial: the campaign stops without a result and writes the page at
    once, without its plots; `ksbo-mav report` draws them, says the campaign is unfinished and counts the
    interrupted trial."""
    from ksbo_mav.campaign import Campaign, CampaignConfig
    from ksbo_mav.errors import VehicleError

    d = tmp_path / "c"
    with sim_and_endpoint() as (sim, ep):
        _set_on_sim(sim, SIM_FAULT_AFTER=5.0, SIM_PILOT_MODE=5)
        with pytest.raises(VehicleError, match="pilot"):
            Campaign(CampaignConfig(dir=str(d), budget=3, seed=0, prior="none", end="hold"), ep,
                     log=lambda s: None).run()
    assert not (d / "result.json").exists()
    # the stop wrote the page at once, without drawing (a stop must be quick), and says what draws the plots
    assert not list((d / "report").glob("*.png"))
    assert f"Plots not drawn: `ksbo-mav report {d}` draws them" in " ".join(_page(d).split())
    assert main(["report", str(d)]) == 0
    assert "report: " in capsys.readouterr().out
    assert (d / "report" / "convergence.png").is_file() and "Plots not drawn" not in _page(d)
    verdict = _verdict(_page(d))
    assert "Unfinished campaign" in verdict and "interrupted (not the gains) 1" in verdict
    assert '<td class="l o">interrupted (pilot' in _page(d)
