"""Public import path of the campaign schema for users' own studies: `Section` (the base of
every schema block) and the campaign file's loader, re-exported from where they live
(`aerotruth.schema`, `aerotruth.sim.campaign_file`). Library modules import those directly."""

from aerotruth.schema import Section
from aerotruth.sim.campaign_file import Campaign, ConfigError, Fleet, Period, References
from aerotruth.sim.campaign_loader import load_campaign, parse_campaign

__all__ = ["Campaign", "ConfigError", "Fleet", "Period", "References", "Section", "load_campaign", "parse_campaign"]
