"""nlid-lab application: run store, campaigns, CLI, views, reports and reanalysis."""

__version__ = "0.1.0"
