"""Shipped controller design artefacts (written by controller.design.design)."""
