"""Campaigns: configuration and validation, devices, the runner and what it tells its watchers.

Modules behind this API: ``_campaign`` (the runner), ``_campaign_config``, ``_campaign_fields``,
``_campaign_devices`` (the device tables), ``_campaign_bench``, ``_observer``, ``_run_header``
(what a run's header stores of the campaign), ``_plans`` (`LevelPlan`, `PLANS`, the runner's
primitives `Runner`) and ``_kinds`` (the kinds campaigns run, one module each: its plan class
and level loop). Code inside this package imports its siblings by their private module path.
"""

from ._campaign import CampaignAborted, run_campaign
from ._campaign_config import CampaignError, load_campaign, load_plant_model, parse_campaign
from ._kinds._stepped import harmonics
from ._observer import CampaignStart, LevelStatus, LevelSummary, NullObserver, PlanInfo
from ._plans import PLANS, LevelPlan, Runner, discover_kinds, register_plan, unregister_plan

__all__ = ["CampaignAborted", "CampaignError", "CampaignStart", "LevelStatus", "LevelSummary",
           "NullObserver",
           "harmonics", "load_campaign", "load_plant_model", "parse_campaign", "run_campaign",
           # the excitation kinds campaigns run
           "PLANS", "LevelPlan", "PlanInfo", "Runner", "discover_kinds", "register_plan",
           "unregister_plan"]
