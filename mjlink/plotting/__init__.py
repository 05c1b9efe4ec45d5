"""Figures: drawing only. Quantities come from :mod:`mjlink.analysis` and the reference."""
