"""The ``synth`` options for artist controls: style regions, water, stamps,
pins, height range (parsing only; :mod:`.cli` runs them).

Option syntax::

    --styles REGIONS.png --style "#RRGGBB=DEM[,relief=S][,base=M]"   (repeatable)
    --water MASK.png --water-level H [--water-depth M] [--bank-width CELLS]
    --stamp DEM[r0:r1,c0:c1]@ROW,COL[,ROT_DEG[,SCALE]]                   (repeatable)
    --pin ROW,COL,HEIGHT                                                  (repeatable)
    --pin-radius CELLS   --height-range LO,HI
"""

from __future__ import annotations

import argparse
import math
import re

from ..errors import ParamsError

_WINDOW = re.compile(r"^(?P<dem>.+?)\[(?P<r0>\d+):(?P<r1>\d+),(?P<c0>\d+):(?P<c1>\d+)\]$")


def add_control_arguments(p: argparse.ArgumentParser) -> None:
    """Add the artist-control options to the ``synth`` parser."""
    g = p.add_argument_group("artist controls")
    g.add_argument("--styles", metavar="REGIONS.png", help="style regions: one flat colour per style")
    g.add_argument("--style", action="append", metavar='"#RRGGBB=DEM[,relief=S][,base=M]"',
                   help="the example DEM for one colour of --styles (repeatable); relief scales its height "
                        "variation, base sets its level in metres")
    g.add_argument("--water", metavar="MASK.png", help="sea, lakes and rivers: dark paint on white")
    g.add_argument("--water-level", type=float, metavar="H", help="water level in metres (needed with --water)")
    g.add_argument("--water-depth", type=float, metavar="M", help="bed depth of wide water below the level, metres")
    g.add_argument("--bank-width", type=float, metavar="CELLS", help="cells over which land eases down to water")
    g.add_argument("--stamp", action="append", metavar="DEM@ROW,COL[,ROT_DEG,SCALE]",
                   help="place a DEM (or DEM[r0:r1,c0:c1], a window of it) centred at ROW,COL, rotated "
                        "counter-clockwise and scaled (repeatable)")
    g.add_argument("--pin", action="append", metavar="ROW,COL,HEIGHT",
                   help="make the output exactly HEIGHT metres at ROW,COL (repeatable)")
    g.add_argument("--pin-radius", type=float, metavar="CELLS", help="how far a pin's correction reaches")
    g.add_argument("--height-range", metavar="LO,HI", help="map the output's heights onto LO..HI metres")
    g.add_argument("--variations", type=int, default=1, metavar="N",
                   help="make N results (at most 64) with seeds SEED..SEED+N-1, one per core at a time "
                        "(OUT_v1, OUT_v2, ...)")


def _numbers(text: str, what: str, count: tuple[int, ...]) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) not in count:
        raise ParamsError(f"{what} {text!r}: expected {' or '.join(str(c) for c in count)} comma-separated numbers")
    return values


def parse_style(text: str) -> tuple[str, str, float, float | None]:
    """``"#RRGGBB=DEM[,relief=S][,base=M]"`` -> (colour, dem, relief, base)."""
    from ..features.labels import parse_colour

    colour, sep, rest = text.partition("=")
    if not sep or not rest:
        raise ParamsError(f"--style {text!r}: expected \"#RRGGBB=DEM\"")
    parse_colour(colour)
    parts = rest.split(",")
    dem, relief, base = parts[0], 1.0, None
    for opt in parts[1:]:
        key, _, value = opt.partition("=")
        try:
            if key.strip() == "relief":
                relief = float(value)
            elif key.strip() == "base":
                base = float(value)
            else:
                raise ValueError
        except ValueError:
            raise ParamsError(f"--style {text!r}: option {opt!r} is not relief=NUMBER or base=METRES") from None
    return colour.strip(), dem.strip(), relief, base


def parse_stamp(text: str):
    """``DEM[r0:r1,c0:c1]@ROW,COL[,ROT,SCALE]`` -> (dem, window, (row, col), rot, scale)."""
    dem, sep, where = text.rpartition("@")
    if not sep or not dem:
        raise ParamsError(f"--stamp {text!r}: expected DEM@ROW,COL[,ROT_DEG,SCALE]")
    values = _numbers(where, f"--stamp {text!r}: position", (2, 3, 4))
    row, col = values[0], values[1]
    rot = values[2] if len(values) > 2 else 0.0
    scale = values[3] if len(values) > 3 else 1.0
    window = None
    m = _WINDOW.match(dem)
    if m:
        dem = m.group("dem")
        window = tuple(int(m.group(k)) for k in ("r0", "r1", "c0", "c1"))
    return dem, window, (row, col), rot, scale


def parse_pin(text: str):
    """``ROW,COL,HEIGHT`` -> Pin."""
    from ..controls.pins import Pin

    row, col, height = _numbers(text, "--pin", (3,))
    if not (math.isfinite(row) and math.isfinite(col)) or row != int(row) or col != int(col):
        raise ParamsError(f"--pin {text!r}: ROW and COL must be whole cells")
    return Pin(int(row), int(col), height)


def controls_from_args(args: argparse.Namespace, *, have_examples: bool):
    """Build :class:`~.synthesis.Controls` from parsed options.

    Returns
    -------
    Controls or None
        None when no control option was given.
    """
    from ..examples import resolve_dem
    from ..features.labels import read_colour_shares, read_label_map, read_mask
    from ..synthesis import Controls, Stamp, Style, Water

    if args.style and not args.styles:
        raise ParamsError("--style needs --styles REGIONS.png saying where each style goes")
    styles, style_map = (), None
    if args.styles:
        if not args.style:
            raise ParamsError(f"--styles {args.styles}: give a --style \"#RRGGBB=DEM\" for each colour; it holds "
                              f"{read_colour_shares(args.styles)}")
        parsed = [parse_style(s) for s in args.style]
        style_map = read_label_map(args.styles, [p[0] for p in parsed], default=have_examples, every_colour=True)
        styles = tuple(Style(resolve_dem(dem), relief_scale=relief, base=base, name=dem)
                       for _, dem, relief, base in parsed)
    water = None
    if args.water:
        if args.water_level is None:
            raise ParamsError(f"--water {args.water}: give the water level with --water-level METRES")
        water = Water(read_mask(args.water), args.water_level, args.water_depth, args.bank_width)
    elif args.water_level is not None:
        raise ParamsError("--water-level needs --water MASK.png")
    stamps = []
    for text in args.stamp:
        dem, window, center, rot, scale = parse_stamp(text)
        stamps.append(Stamp(resolve_dem(dem), center, rot, scale, window))
    pins = tuple(parse_pin(t) for t in args.pin)
    height_range = tuple(_numbers(args.height_range, "--height-range", (2,))) if args.height_range else None
    if not (styles or water or stamps or pins or height_range):
        return None
    if water is not None and style_map is not None and water.mask.shape != style_map.shape:
        raise ParamsError(f"--water {args.water} is {water.mask.shape[1]}x{water.mask.shape[0]} pixels but --styles "
                          f"{args.styles} is {style_map.shape[1]}x{style_map.shape[0]}: paint both on the same grid")
    return Controls(styles=styles, style_map=style_map, water=water, stamps=tuple(stamps), pins=pins,
                    height_range=height_range, pin_radius=args.pin_radius)
