"""`seagen verify`: check the C committed in a folder against the model it was exported from."""
