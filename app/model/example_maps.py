"""Built-in multi-style maps (the core's presets) as documents.

The core's :func:`~terrasynth_core.presets.load_preset` returns the styles
and stamps as loaded height fields; a document needs them as
:class:`ExampleRef` so that a project saved from it names the built-in
DEMs instead of embedding them.  So the preset's JSON is read here again,
with the same meaning: styles in the JSON's order are style ids 0, 1, ...;
its style map, water mask and sketch are PNGs beside it.
"""

from __future__ import annotations

import json
from pathlib import Path

from terrasynth_core.errors import ParamsError, SketchError
from terrasynth_core.examples import BUILTIN_PREFIX, resource_path
from terrasynth_core.features import read_sketch
from terrasynth_core.features.labels import read_label_map, read_mask
from terrasynth_core.presets import PRESETS
from terrasynth_core.synthesis import Pin, SynthesisParams

from .control_specs import StampSpec, StyleSpec
from .document import Document
from .example_library import ExampleRef
from .sketch_layers import Sketch

#: Example maps the app offers: preset key -> title for menus.
EXAMPLE_MAPS = {"middle-earth": "Middle-earth"}


def example_map_document(key: str) -> Document:
    """A new, unsaved document holding the built-in map ``key``: its sketch
    and size, styles, style regions, water and level, stamps, pins and the
    cell size it was designed at.

    Reads the stamp DEMs for their sizes (about a second): call it off the
    GUI thread.  The plain example list is empty, since the map's styles
    cover every cell.  A water ``depth`` or ``bank_width`` in the JSON is
    not kept (documents use the core's defaults).

    Raises
    ------
    ParamsError
        Unknown ``key`` (the message lists the known ones).
    TerraSynthError
        An unreadable map file or DEM.
    """
    if key not in PRESETS:
        raise ParamsError(f"unknown example map {key!r}; expected one of {', '.join(sorted(PRESETS))}")
    json_path = resource_path("sketches", PRESETS[key])
    folder = json_path.parent
    spec = json.loads(json_path.read_text(encoding="utf-8"))

    names = spec.get("style_names", {})
    styles = []
    for index, (colour, dem) in enumerate(spec["styles"].items()):
        ref = _example_ref(dem, folder)
        styles.append(StyleSpec(index, names.get(colour) or ref.label, colour, ref))
    sketch_map = read_sketch(folder / spec["sketch"])
    shape = sketch_map.shape
    # Strict reading, as the core's preset: every pixel belongs to a style.
    style_layer = read_label_map(folder / spec["style_map"], [s.color for s in styles])
    water = spec.get("water")
    water_layer = read_mask(folder / water["mask"]) if water else None
    strokes = Sketch.from_sketch_map(sketch_map)
    sketch = Sketch(strokes.ridge, strokes.valley, style=_at_shape(style_layer, shape, spec["style_map"]),
                    water=None if water_layer is None else _at_shape(water_layer, shape, water["mask"]))

    stamps = []
    for entry in spec.get("stamps", [spec["stamp"]] if "stamp" in spec else []):
        window = entry.get("window")
        ref = _example_ref(entry["dem"], folder, crop=tuple(window) if window else None)
        stamps.append(StampSpec(ref, tuple(entry["center"]), ref.load().shape, float(entry.get("rotation", 0.0)),
                                float(entry.get("scale", 1.0))))
    pins = [Pin(int(p["row"]), int(p["col"]), float(p["height"])) for p in spec.get("pins", [])]
    # The cell size the map was designed at, as the core's preset carries it.
    params = SynthesisParams(cell_size=float(spec["cell_size"])) if spec.get("cell_size") else SynthesisParams()
    return Document(sketch, [], params=params, styles=styles, water_level=float(water["level"]) if water else 0.0,
                    pins=pins, stamps=stamps, next_style_id=len(styles))


def _example_ref(dem: str, folder: Path, *, crop=None) -> ExampleRef:
    """``builtin:KEY`` or a DEM path relative to the map's folder."""
    if dem.startswith(BUILTIN_PREFIX):
        return ExampleRef(builtin=dem[len(BUILTIN_PREFIX):], crop=crop)
    return ExampleRef(path=str(folder / dem), crop=crop)


def _at_shape(layer, shape: tuple[int, int], name: str):
    if layer.shape != tuple(shape):
        raise SketchError(f"example map {name} is {layer.shape[1]}x{layer.shape[0]} pixels but its sketch is "
                          f"{shape[1]}x{shape[0]}")
    return layer
