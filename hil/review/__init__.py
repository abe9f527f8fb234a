"""Reviewing a run from its MCAP log alone: summary, KPIs, plots, the exit-code outcome, forecast
analysis."""
