"""Python twins of the hand-written C runtime (c_runtime/): one module per C file, same names and integers."""
