"""Jinja templates of the generated C, shipped as package data."""
