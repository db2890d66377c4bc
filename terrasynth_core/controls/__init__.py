"""Artist controls beyond the sketch: style regions and their level field,
stamps, elevation pins, water and the height range."""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:
    from .options import Controls, Stamp, Style
    from .pins import Pin, PinError
    from .water import Water

# Loaded on first use (terrasynth_core._lazy): importing the package costs nothing.
__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    ".options": ("Controls", "Stamp", "Style"),
    ".pins": ("Pin", "PinError"),
    ".water": ("Water",),
})
