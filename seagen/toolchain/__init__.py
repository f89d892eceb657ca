"""Building C: cffi modules on the host, and cross-compiled runs on an emulated Cortex-M core."""
