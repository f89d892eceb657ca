"""Processor in the loop: the exported firmware on an emulated board (QEMU) against the Python plant."""
