"""Discrepancy workflow: replay measured runs, find where they disagree, name and add the missing effect."""
