"""Make the hillshade thumbnails of the built-in examples (resources/thumbnails)."""

from __future__ import annotations

import numpy as np
from PIL import Image

from terrasynth_core.measures import hillshade
from terrasynth_core.examples import BUILTIN_EXAMPLES, resource_path

SIZE = 160


def main() -> None:
    folder = resource_path("thumbnails")
    folder.mkdir(exist_ok=True)
    for ex in BUILTIN_EXAMPLES:
        field = ex.load()
        shade = hillshade(field.heights, cell_size=field.cell_size)
        img = Image.fromarray((np.nan_to_num(shade) * 255).astype(np.uint8))
        img.thumbnail((SIZE, SIZE), Image.LANCZOS)
        img.save(ex.thumbnail_path, optimize=True)
        print(f"{ex.thumbnail_path}: {img.size[0]}x{img.size[1]} from {field.shape}")


if __name__ == "__main__":
    main()
