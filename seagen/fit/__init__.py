"""Calibration and control models: kinematics baseline, surface fit, MLPs, search, the model file."""
