"""Quantization: Q-format choice, interval analysis, float IR -> quantized IR, and the integer primitives."""
