"""Campaigns: configuration and validation, devices, the runner and what it tells its watchers.

Modules behind this API: ``_campaign``, ``_campaign_config``, ``_campaign_fields``,
``_campaign_devices`` (the device tables), ``_campaign_bench``, ``_campaign_sweep``,
``_observer``, ``_plans`` (the kinds campaigns run: `LevelPlan`, `PLANS`). Code inside this
package imports its siblings by their private module path.
"""

from ._campaign import CampaignAborted, harmonics, run_campaign
from ._campaign_config import CampaignError, load_campaign, load_plant_model, parse_campaign
from ._observer import CampaignStart, LevelStatus, LevelSummary, NullObserver
from ._plans import PLANS, LevelPlan, register_plan, unregister_plan

__all__ = ["CampaignAborted", "CampaignError", "CampaignStart", "LevelStatus", "LevelSummary",
           "NullObserver",
           "harmonics", "load_campaign", "load_plant_model", "parse_campaign", "run_campaign",
           # the excitation kinds campaigns run
           "PLANS", "LevelPlan", "register_plan", "unregister_plan"]
