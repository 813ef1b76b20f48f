"""`ksbo-mav demo`, the README's first command, end to end: its console names each trial as its report does."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.campaign.report.rows import read_campaign

pytestmark = [pytest.mark.network, pytest.mark.timeout(240)]

TRIAL_LINE = re.compile(r"^trial +(\d+) (.+?) +P [+-]\d")


def test_demo_console_and_report_name_every_trial_alike(tmp_path):
    d = tmp_path / "demo"
    r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "demo", "--budget", "3", "--dir", str(d)],
                       capture_output=True, text=True, timeout=220, cwd=tmp_path)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    console = {int(m[1]): m[2].strip() for m in map(TRIAL_LINE.match, r.stderr.splitlines()) if m}
    rows = read_campaign(CampaignDir.at(d), rms=False).rows
    assert console == {row.trial: row.role for row in rows}
    assert console[0] == "baseline" and "confirmation" in console.values()
    # The progress display writes to stderr, the result to stdout: one duration line, named for what it
    # measures, and the summary's own figure says what it covers.
    assert re.search(r"^demo: \d+ s in all, from connecting to the written report", r.stdout, re.M)
    assert "for the prior, the trials and the confirmation" in r.stdout
