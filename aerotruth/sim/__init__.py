"""Campaigns: expansion, seeding, executors, result store, regression, figures, report."""
