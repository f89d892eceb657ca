"""Hand-written C runtime shipped as package data (see README.md here)."""
