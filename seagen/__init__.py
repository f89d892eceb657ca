"""seagen: integer-only C for data-driven SEA calibration and control models."""

__version__ = "0.1.0"
