"""Typed errors of TerraSynth.

Every error a user can cause derives from :class:`TerraSynthError`, whose
message is one readable line naming the file or value at fault and what was
expected.  Front ends (the CLI, the app) catch this one class and show the
message instead of a traceback.
"""

from __future__ import annotations


class TerraSynthError(ValueError):
    """Base class of all errors caused by bad input or bad parameters."""


class DEMFormatError(TerraSynthError):
    """A DEM file cannot be read or written: unknown extension, corrupt or
    truncated content, wrong size, no valid heights."""


class SketchError(TerraSynthError):
    """A sketch map cannot be read or interpreted."""


class ParamsError(TerraSynthError):
    """A parameter value is out of range or inconsistent with the inputs."""


class SynthesisCancelled(Exception):
    """Raised by ``run`` when the caller's cancel check asked to stop.

    Not a :class:`TerraSynthError`: cancelling is not a mistake.
    """


class ProjectError(TerraSynthError):
    """A project file (``.tsproj``) cannot be read or written: missing,
    damaged, of a newer version, or holding layers too large to read."""
