"""Style-label and water-mask PNGs."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from terrasynth_core.errors import SketchError
from terrasynth_core.features.labels import read_colour_shares, read_label_map, read_mask




def test_label_and_water_pngs(tmp_path):
    rgb = np.zeros((20, 30, 3), np.uint8)
    rgb[:, :15] = (0, 128, 0)
    rgb[:, 15:] = (128, 64, 0)
    rgb[:, 15] = (64, 96, 0)  # an anti-aliased edge column
    Image.fromarray(rgb).save(tmp_path / "styles.png")
    labels = read_label_map(tmp_path / "styles.png", ["#008000", "#804000"])
    assert (labels[:, :15] == 0).all() and (labels[:, 16:] == 1).all()
    rgb[:10, :10] = (255, 0, 255)
    Image.fromarray(rgb).save(tmp_path / "extra.png")
    with pytest.raises(SketchError, match="#ff00ff"):
        read_label_map(tmp_path / "extra.png", ["#008000", "#804000"])
    assert (read_label_map(tmp_path / "extra.png", ["#008000", "#804000"], default=True)[:10, :10] == -1).all()
    water = np.full((20, 30), 255, np.uint8)
    water[5:8] = 0
    Image.fromarray(water).save(tmp_path / "water.png")
    mask = read_mask(tmp_path / "water.png")
    assert mask[5:8].all() and mask.sum() == 3 * 30
    with pytest.raises(SketchError, match="does not exist"):
        read_mask(tmp_path / "nope.png")


def test_a_style_colour_that_paints_nothing_is_named_with_the_maps_colours(tmp_path):
    rgb = np.zeros((20, 30, 3), np.uint8)
    rgb[:, :20] = (0, 128, 0)
    rgb[:, 20:] = (128, 64, 0)
    Image.fromarray(rgb).save(tmp_path / "styles.png")
    # A mistyped colour: by default it is a style nothing uses (the app's
    # styles may outnumber a map's colours), asked for, an error.
    labels = read_label_map(tmp_path / "styles.png", ["#008000", "#804000", "#123456"], default=True)
    assert set(np.unique(labels)) == {0, 1}
    with pytest.raises(SketchError, match=r"no pixel of style colour #123456; its colours are "
                                          r"#008000 \(67 %\), #804000 \(33 %\)"):
        read_label_map(tmp_path / "styles.png", ["#008000", "#804000", "#123456"], default=True, every_colour=True)
    assert read_colour_shares(tmp_path / "styles.png") == "#008000 (67 %), #804000 (33 %)"
    with pytest.raises(SketchError, match="style colour #008000 is given more than once"):
        read_label_map(tmp_path / "styles.png", ["#008000", "#008000", "#804000"], every_colour=True)
    # A sliver of a near colour (kept as anti-aliasing) does not paint a mistyped style.
    rgb[0, 0] = (0, 20, 230)  # nearest #123456, but past the tolerance: stray
    Image.fromarray(rgb).save(tmp_path / "sliver.png")
    with pytest.raises(SketchError, match="no pixel of style colour #123456"):
        read_label_map(tmp_path / "sliver.png", ["#008000", "#804000", "#123456"], every_colour=True)
