"""Data sets: the paper's calibration protocol, the CSV schema, validated loading, the feature function."""
