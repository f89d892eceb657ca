"""The closed loop (the simulated SEA with the C controller or its twin) and the paper's Table II."""
