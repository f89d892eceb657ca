"""The integer references: numpy (the executable spec), its torch twin, and the ONNX graph."""
