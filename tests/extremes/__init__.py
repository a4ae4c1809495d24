"""Numerical extremes and bad input at every public entry point (issue 11)."""
