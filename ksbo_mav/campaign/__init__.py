"""Tuning campaigns on a MAVLink vehicle: settings, directory layout, journal and replay, the runner, restore and
accept, the report. See :mod:`ksbo_mav.campaign.runner` for the order of flights (and the module of each step),
:mod:`ksbo_mav.campaign.config` for which value a setting takes and :mod:`ksbo_mav.campaign.layout` for the
files."""

from ksbo_mav.campaign.access import accept_campaign, restore_snapshot
from ksbo_mav.campaign.config import CampaignConfig, optimizer_options
from ksbo_mav.campaign.journal import Journal, JournalEntry
from ksbo_mav.campaign.layout import CampaignDir
from ksbo_mav.campaign.runner import Campaign
from ksbo_mav.campaign.summary import CampaignSummary, TrialEvent
from ksbo_mav.campaign.validation_session import validate_campaign, validation_verdicts

__all__ = ["Campaign", "CampaignConfig", "CampaignDir", "CampaignSummary", "Journal", "JournalEntry", "TrialEvent",
           "accept_campaign", "optimizer_options", "restore_snapshot", "validate_campaign", "validation_verdicts"]
