"""Artist controls beyond the sketch: style regions and their level field,
stamps, elevation pins, water and the height range."""

from .options import Controls, Stamp, Style
from .pins import Pin, PinError
from .water import Water

__all__ = ["Controls", "Pin", "PinError", "Stamp", "Style", "Water"]
