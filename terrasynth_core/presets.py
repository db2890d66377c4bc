"""Built-in multi-style maps: a JSON file beside its PNGs in
``resources/sketches`` naming the style colours, water, stamp and pins.

The Middle-earth-like map (``middle-earth``) is the paper's showcase redone:
four styles, a sea, a lake and a river, Mount St. Helens as a stamp, and
elevation pins.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

from .errors import ParamsError
from .examples import resolve_dem, resource_path
from .features import SketchMap, read_sketch
from .features.labels import read_label_map, read_mask
from .controls.pins import Pin
from .controls.options import Controls, Stamp, Style
from .controls.water import Water

#: Preset name -> JSON file in resources/sketches.
PRESETS = {"middle-earth": "middle_earth.json"}


@dataclass(frozen=True, eq=False)
class MapPreset:
    """A ready multi-style problem.

    Parameters
    ----------
    name : str
    shape : (rows, cols)
    sketch : SketchMap
    controls : Controls
    style_names : dict of str -> str
        Example key -> what the region stands for (for captions).
    cell_size : float or None
        The cell size in metres the map was designed at, for
        ``SynthesisParams(cell_size=...)`` (None: the finest style's).
    """

    name: str
    shape: tuple[int, int]
    sketch: SketchMap
    controls: Controls
    style_names: dict
    cell_size: float | None = None


def load_preset(name: str) -> MapPreset:
    """Read a built-in map preset.

    Raises
    ------
    ParamsError
        Unknown preset name (the message lists the known ones).
    """
    if name not in PRESETS:
        raise ParamsError(f"unknown map preset {name!r}; expected one of {', '.join(sorted(PRESETS))}")
    spec = json.loads(resource_path("sketches", PRESETS[name]).read_text(encoding="utf-8"))
    colours = list(spec["styles"])
    styles = tuple(Style(resolve_dem(spec["styles"][c]), name=spec.get("style_names", {}).get(c, spec["styles"][c]))
                   for c in colours)
    style_map = read_label_map(resource_path("sketches", spec["style_map"]), colours)
    water = None
    if "water" in spec:
        w = spec["water"]
        water = Water(read_mask(resource_path("sketches", w["mask"])), float(w["level"]), w.get("depth"),
                      w.get("bank_width"))
    stamps = []
    for st in spec.get("stamps", [spec["stamp"]] if "stamp" in spec else []):
        stamps.append(Stamp(resolve_dem(st["dem"]), tuple(st["center"]), float(st.get("rotation", 0.0)),
                            float(st.get("scale", 1.0)), tuple(st["window"]) if st.get("window") else None))
    pins = tuple(Pin(int(p["row"]), int(p["col"]), float(p["height"])) for p in spec.get("pins", []))
    controls = Controls(styles=styles, style_map=style_map, water=water, stamps=tuple(stamps), pins=pins)
    sketch = read_sketch(resource_path("sketches", spec["sketch"]))
    names = {spec["styles"][c]: spec.get("style_names", {}).get(c, spec["styles"][c]) for c in colours}
    cell_size = float(spec["cell_size"]) if spec.get("cell_size") is not None else None
    return MapPreset(name, tuple(spec["shape"]), sketch, controls, names, cell_size)
