"""TerraSynth desktop app (installed as ``terrasynth_app``).

Layers, dependencies pointing one way: :mod:`.views` (Qt widgets) use
:mod:`.controllers` (Qt objects that run work and report it) and
:mod:`.model` (plain Python, no Qt), which uses :mod:`terrasynth_core`.
:mod:`.workers` drains any generator of events on a thread, one signal per
item, for the controllers (and runs one-off jobs on the thread pool).
"""
