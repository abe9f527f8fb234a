"""Campaigns of cases x seeds x controllers, their KPIs, the operating-envelope check and the HTML
report."""
