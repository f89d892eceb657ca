"""Controller twins (fixed-point PID, the paper's two-level controller) and the closed-loop simulation."""
