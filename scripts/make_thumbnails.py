"""Make the hillshade thumbnails of the built-in examples (resources/thumbnails)."""

from __future__ import annotations

from PIL import Image

from terrasynth_core.examples import BUILTIN_EXAMPLES, resource_path
from terrasynth_core.pictures import grey_hillshade

SIZE = 160


def main() -> None:
    folder = resource_path("thumbnails")
    folder.mkdir(exist_ok=True)
    for ex in BUILTIN_EXAMPLES:
        field = ex.load()
        img = Image.fromarray(grey_hillshade(field.heights, cell_size=field.cell_size))
        img.thumbnail((SIZE, SIZE), Image.LANCZOS)
        img.save(ex.thumbnail_path, optimize=True)
        print(f"{ex.thumbnail_path}: {img.size[0]}x{img.size[1]} from {field.shape}")


if __name__ == "__main__":
    main()
