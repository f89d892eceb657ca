"""The simulated series elastic actuator of Guo et al. (2021): physics, effects, sensors, stepping."""

from seagen.plant.config import EFFECT_NAMES, PlantConfig, load_config, save_config
from seagen.plant.sim import Plant, Sensors, pick

__all__ = ["EFFECT_NAMES", "Plant", "PlantConfig", "Sensors", "load_config", "pick", "save_config"]
