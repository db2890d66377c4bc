"""Does the output keep its examples' slopes in metres per metre?

Every built-in example is synthesized at the run's square cell size (the
finest example's, see ``SynthesisParams.cell_size``) on the Y-junction
sketch (512x512), seeds 0-2.  The output's median slope (m/m, at its cell
size) is compared with the example's own median slope at its *true* cell
size, measured on the original grid with its own (dy, dx), nodata left out.
Target: a ratio of 0.85-1.15.

Then two style regions of different resolutions (Big Tujunga, 30 m, left;
White Mountains, 93 x 66 m, right), once at the automatic cell size (30 m)
and once at 60 m: each region's interior (eroded by half a patch) against
its own example.  Target: within 20 %.  A DEM's slope depends on the cell
it is measured at (a coarser grid averages the steepest cells away), so the
example's slope at the run's cell size (resampled as the engine sees it) is
shown as well: that is what synthesis can reproduce at best.  ``alone``
is the same example synthesized alone at the same cell size (same sketch,
seed and interior): the difference to it is what the neighbouring style
does to a region.

Usage::

    python benchmarks/eval_ground_scale.py [--seeds 3] [--pictures DIR] [--part single|styles]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy import ndimage

from terrasynth_core.errors import ParamsError
from terrasynth_core.examples import builtin_example, resource_path
from terrasynth_core.io.resample import to_square_cells
from terrasynth_core.features import read_sketch
from terrasynth_core.measures import slope
from terrasynth_core.pictures import save_png, shaded_relief
from terrasynth_core.synthesis import Controls, Session, Style, SynthesisParams

KEYS = ("white-mountains", "gabon-plateau", "big-tujunga", "himalaya", "st-helens")
SHAPE = (512, 512)


def median_slope(heights, cell_size) -> float:
    """Median slope in metres per metre (nodata left out)."""
    degrees = slope(heights, cell_size=cell_size)
    return float(np.tan(np.radians(np.nanmedian(degrees))))


def _picture(folder: Path | None, name: str, heights, cell) -> None:
    if folder is not None:
        folder.mkdir(parents=True, exist_ok=True)
        save_png(shaded_relief(heights, cell_size=(cell, cell)), folder / f"{name}.png")


def single_examples(seeds: int, pictures: Path | None) -> list[float]:
    sketch = read_sketch(resource_path("sketches") / "y_junction_512.png")
    print(f"{'example':<16} {'true cell (m)':>15} {'out cell':>8} {'patch':>5} {'seed':>4} {'sec':>5} "
          f"{'example m/m':>11} {'output m/m':>10} {'ratio':>6}")
    print("-" * 92)
    ratios = []
    for key in KEYS:
        field = builtin_example(key).load()
        own = median_slope(field.heights, field.cell_size)
        for seed in range(seeds):
            for patch in (80, 48):
                try:
                    t = time.perf_counter()
                    result = Session([field], sketch, shape=SHAPE,
                                     params=SynthesisParams(seed=seed, patch_size=patch)).run()
                    break
                except ParamsError:
                    if patch == 48:
                        raise
            sec = time.perf_counter() - t
            cell = result.cell_size
            out = median_slope(result.heights, (cell, cell))
            ratios.append(out / own)
            dy, dx = field.cell_size
            print(f"{key:<16} {dy:>6.1f} x {dx:>6.1f} {cell:>8.1f} {patch:>5} {seed:>4} {sec:>5.1f} "
                  f"{own:>11.3f} {out:>10.3f} {out / own:>6.2f}")
            if seed == 0:
                _picture(pictures, f"ground_{key}", result.heights, cell)
    return ratios


def two_styles(pictures: Path | None) -> list[float]:
    tujunga, white = builtin_example("big-tujunga").load(), builtin_example("white-mountains").load()
    labels = np.zeros(SHAPE, np.int16)
    labels[:, SHAPE[1] // 2:] = 1
    sketch = read_sketch(resource_path("sketches") / "y_junction_512.png")
    print()
    print(f"{'cell size':<10} {'region':<16} {'example m/m':>11} {'at run cell':>11} {'region m/m':>10} "
          f"{'ratio':>6} {'ratio at run cell':>17} {'alone':>6}")
    print("-" * 95)
    ratios = []
    for cell_size in (None, 60.0):
        controls = Controls(styles=(Style(tujunga, name="big-tujunga"), Style(white, name="white-mountains")),
                            style_map=labels)
        params = SynthesisParams(seed=0, cell_size=cell_size)
        result = Session([], sketch, shape=SHAPE, params=params, controls=controls).run()
        cell = result.cell_size
        per_cell = slope(result.heights, cell_size=(cell, cell))
        for label, (name, field) in enumerate((("big-tujunga", tujunga), ("white-mountains", white))):
            inside = ndimage.binary_erosion(labels == label, iterations=result.params.patch_size // 2, border_value=1)
            out = float(np.tan(np.radians(np.nanmedian(per_cell[inside]))))
            solo = Session([field], sketch, shape=SHAPE, params=replace(params, cell_size=cell)).run()
            alone = float(np.tan(np.radians(np.nanmedian(slope(solo.heights, cell_size=(cell, cell))[inside]))))
            own = median_slope(field.heights, field.cell_size)
            seen = median_slope(to_square_cells(field, cell).crop_valid().heights, (cell, cell))
            ratios.append(out / own)
            asked = "auto" if cell_size is None else f"{cell_size:g}"
            print(f"{asked + f' ({cell:g})':<10} {name:<16} {own:>11.3f} {seen:>11.3f} {out:>10.3f} "
                  f"{out / own:>6.2f} {out / seen:>17.2f} {alone / own:>6.2f}")
        _picture(pictures, f"ground_styles_{cell:g}m", result.heights, cell)
    return ratios


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--pictures", type=Path, help="write hillshades of the outputs there")
    parser.add_argument("--part", choices=("single", "styles"), help="only one of the two tables")
    args = parser.parse_args()
    single = single_examples(args.seeds, args.pictures) if args.part != "styles" else []
    styles = two_styles(args.pictures) if args.part != "single" else []
    print()
    print(f"single examples: {sum(0.85 <= r <= 1.15 for r in single)}/{len(single)} within 0.85-1.15; "
          f"style regions: {sum(0.8 <= r <= 1.2 for r in styles)}/{len(styles)} within 20 %")


if __name__ == "__main__":
    main()
