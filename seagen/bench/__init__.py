"""Benchmarks of generated C on emulated Cortex-M cores: `seagen bench`, `make bench` (drivers at the top)."""
