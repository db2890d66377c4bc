"""The README's picture of the masks: docs/images/masks_<example>.png.

Usage::

    python scripts/render_masks.py [--example big-tujunga] [--side 512] [--out docs/images]

The masks are made exactly as ``terrasynth-cli masks`` makes them
(:func:`terrasynth_core.export.terrain_masks`) on the built-in example,
cropped to a ``side`` square, and laid out with the shaded relief.  Height
bands (four channels) are shown as four colours, the normal map as is.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from terrasynth_core.examples import resolve_dem
from terrasynth_core.export import terrain_masks
from terrasynth_core.export.engines import engine_ready
from terrasynth_core.pictures import compose, fit_panel, mask_picture, save_png, shaded_relief


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--example", default="big-tujunga")
    parser.add_argument("--side", type=int, default=512)
    parser.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "images"))
    args = parser.parse_args(argv)
    field, _ = engine_ready(resolve_dem(f"builtin:{args.example}"))
    n = min(args.side, *field.shape)
    r0, c0 = (field.shape[0] - n) // 2, (field.shape[1] - n) // 2
    field = field.window(r0, r0 + n, c0, c0 + n)
    masks = terrain_masks(field).masks
    panels = [shaded_relief(field.heights, cell_size=field.cell_size)[..., :3]]
    labels = ["terrain"]
    for name, label in (("slope", "slope"), ("convex", "convex"), ("concave", "concave"), ("flow", "flow"),
                        ("wetness", "wetness"), ("height_bands", "height bands (RGBA)"), ("normal", "normal map")):
        panels.append(mask_picture(masks[name]))
        labels.append(label)
    sheet = compose([fit_panel(p, 300) for p in panels], labels,
                    f"terrasynth-cli masks builtin:{args.example} ({n} x {n}, {field.cell_size[0]:.0f} m cells)",
                    columns=4)
    out = Path(args.out) / f"masks_{args.example}.png"
    out.parent.mkdir(parents=True, exist_ok=True)
    save_png(sheet, out, max_bytes=900_000)  # quantized to 256 colours when larger
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
