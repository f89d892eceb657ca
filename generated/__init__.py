"""The exports of the default models (package data: seagen.generated)."""
