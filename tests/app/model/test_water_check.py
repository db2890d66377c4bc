"""Drowned land and the hover readout, without Qt."""

import numpy as np

from terrasynth_app.model import Document, ExampleRef, Sketch, TerrainResult
from terrasynth_app.model.readout import cell_readout
from terrasynth_app.model.water_check import document_drowning, drowned_land


def _terrain(heights):
    return TerrainResult(heights, np.zeros(heights.shape, np.int32), np.zeros(heights.shape, bool),
                         cell_size=(10.0, 10.0))


def test_drowned_land_counts_unpainted_cells_below_the_level_and_the_level_that_drowns_none():
    heights = np.tile(np.arange(10, dtype=np.float32) * 10.0 + 0.25, (10, 1))  # 0.25 m to 90.25 m, rising east
    water = np.zeros((10, 10), bool)
    water[:, 0] = True
    assert drowned_land(heights, water, 5.0) is None  # only the painted column is below
    drowning = drowned_land(heights, water, 35.0)
    assert drowning.cells == 30 and drowning.share == 0.3
    assert drowning.safe_level == 10.2  # the lowest land, rounded down to 0.1 m
    assert drowned_land(heights, water, drowning.safe_level) is None
    assert "30.0%" in drowning.message() and "35 m" in drowning.message()
    assert "drawn dry" in drowning.message(connected_only=True)


def test_a_document_without_water_or_terrain_has_nothing_drowned():
    doc = Document(Sketch.blank((10, 10)), [ExampleRef(builtin="white-mountains")], water_level=50.0)
    assert document_drowning(doc) is None
    doc.set_result(_terrain(np.zeros((10, 10), np.float32)))
    assert document_drowning(doc) is None  # no painted water: the engine adds none
    water = np.zeros((10, 10), bool)
    water[0, 0] = True
    doc.sketch.replace_regions(water=water)
    assert document_drowning(doc).cells == 99


def test_the_readout_tells_row_col_height_slope_water_and_style():
    heights = np.tile(np.arange(10, dtype=np.float32) * 10.0, (10, 1))  # 10 m up per 10 m cell: 45 degrees
    doc = Document(Sketch.blank((10, 10)), [ExampleRef(builtin="white-mountains")], water_level=25.0)
    assert cell_readout(doc, 3, 4) == "row 3, col 4"  # no terrain yet
    doc.set_result(_terrain(heights))
    assert cell_readout(doc, 3, 4) == "row 3, col 4: 40.0 m, slope 45.0°"
    assert cell_readout(doc, 10, 0) is None
    style = doc.add_style(ExampleRef(builtin="himalaya"), name="Highlands")
    water = np.zeros((10, 10), bool)
    water[:, 0] = True
    styles = np.full((10, 10), -1)
    styles[:, :3] = style.id
    doc.sketch.replace_regions(style=styles, water=water)
    assert cell_readout(doc, 3, 2) == "row 3, col 2: 20.0 m, slope 45.0°, 5.0 m under water, style Highlands"
