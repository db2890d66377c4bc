"""TerraSynth desktop app (installed as ``terrasynth_app``).

Layers, dependencies pointing one way: :mod:`.views` (Qt widgets) use
:mod:`.model` (plain Python, no Qt), which uses :mod:`terrasynth_core`.
:mod:`.workers` runs the core's ``Session.iter_run`` on a thread and turns its
events into Qt signals.
"""
