"""Quantization: Q-format choice, interval analysis (overflow, error bound), float IR -> quantized IR."""
