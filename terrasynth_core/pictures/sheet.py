"""Contact sheets: pictures in a labelled grid under a title (the README's
gallery, the Middle-earth sheet, the fidelity sheets)."""

from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw, ImageFont

#: Pixels between panels and around the grid.
MARGIN = 12


def fit_panel(rgb: np.ndarray, side: int) -> Image.Image:
    """The picture (uint8 RGB array) scaled (Lanczos) so its longer side is ``side`` pixels."""
    img = Image.fromarray(rgb)
    f = side / max(img.size)
    return img.resize((max(1, round(img.size[0] * f)), max(1, round(img.size[1] * f))), Image.LANCZOS)


def compose(panels: list[Image.Image], labels: list[str], title: str, *, columns: int,
            margin: int = MARGIN) -> Image.Image:
    """Panels in a grid of ``columns``, row by row, with a label over each
    and a title on top, on white; every cell is as large as the largest
    panel, smaller panels centred in theirs."""
    title_font, label_font = ImageFont.load_default(size=20), ImageFont.load_default(size=16)
    cell_w = max(p.size[0] for p in panels)
    cell_h = max(p.size[1] for p in panels)
    label_h, title_h = 26, 34
    grid_rows = -(-len(panels) // columns)
    width = columns * cell_w + (columns + 1) * margin
    height = title_h + grid_rows * (label_h + cell_h) + (grid_rows + 1) * margin // 2 + margin // 2
    canvas = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(canvas)
    draw.text((margin, 8), title, fill=(20, 20, 20), font=title_font)
    for i, (panel, label) in enumerate(zip(panels, labels)):
        r, c = divmod(i, columns)
        x = margin + c * (cell_w + margin)
        y = title_h + margin // 2 + r * (label_h + cell_h + margin // 2)
        draw.text((x, y + 2), label, fill=(40, 40, 40), font=label_font)
        canvas.paste(panel, (x + (cell_w - panel.size[0]) // 2, y + label_h))
    return canvas
