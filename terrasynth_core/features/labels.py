"""Painted maps besides the sketch: style regions (one flat colour per
style) and water masks (dark paint on a light ground).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from PIL import UnidentifiedImageError

from ..errors import SketchError
from .sketch import open_image

_HEX = re.compile(r"^#?([0-9a-fA-F]{6})$")

#: A pixel within this RGB distance of a listed colour belongs to it.
COLOUR_TOLERANCE = 96.0
#: Pixels near no listed colour are tolerated (given to the nearest) up to
#: this share of the image: anti-aliased edges between two regions.
STRAY_SHARE = 0.005


def parse_colour(text: str) -> tuple[int, int, int]:
    """``"#RRGGBB"`` (or without ``#``) as an (r, g, b) tuple.

    Raises
    ------
    SketchError
        Not six hexadecimal digits.
    """
    m = _HEX.match(str(text).strip())
    if not m:
        raise SketchError(f"colour {text!r} is not #RRGGBB (six hexadecimal digits)")
    v = m.group(1)
    return int(v[0:2], 16), int(v[2:4], 16), int(v[4:6], 16)


def colour_hex(rgb) -> str:
    """An (r, g, b) colour, 0-255 each, as ``"#rrggbb"`` (:func:`parse_colour`'s inverse)."""
    return "#{:02x}{:02x}{:02x}".format(*(int(v) for v in rgb))


def _read_rgba(path: Path, what: str) -> np.ndarray:
    try:
        with open_image(path, what) as image:
            image.load()
            rgba = np.asarray(image.convert("RGBA"))
    except FileNotFoundError:
        raise SketchError(f"{what} file {path} does not exist") from None
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        raise SketchError(f"cannot read {what} {path}: not a readable image ({exc})") from None
    if min(rgba.shape[:2]) < 2:
        raise SketchError(f"{what} {path} is only {rgba.shape[1]}x{rgba.shape[0]} pixels; expected at least 2x2")
    return rgba


def colour_shares(rgba: np.ndarray, most: int = 6) -> str:
    """The image's commonest opaque colours and their shares, for messages
    (``"#8a6a55 (62 %), #3070c0 (38 %)"``).

    Parameters
    ----------
    rgba : ndarray of uint8, shape (rows, cols, 4)
    most : int
        Colours named at most.
    """
    opaque = rgba[..., 3] >= 128
    if not opaque.any():
        return "no opaque pixel"
    values, counts = np.unique(rgba[..., :3][opaque], axis=0, return_counts=True)
    order = np.argsort(-counts, kind="stable")[:most]  # (ties in colour order)
    return ", ".join(f"{colour_hex(values[i])} ({100 * counts[i] / rgba[..., 0].size:.0f} %)" for i in order)


def label_map_from_rgba(rgba: np.ndarray, colours, *, default: bool = False, name: str = "style map",
                        every_colour: bool = False) -> np.ndarray:
    """Style labels from an RGBA image.

    Parameters
    ----------
    rgba : ndarray of uint8, shape (rows, cols, 4)
    colours : sequence of (r, g, b) or "#RRGGBB"
        The colour of style 0, 1, ...
    default : bool
        Whether unlisted colours and transparent pixels may fall to label -1
        (the plain examples).  Otherwise they are an error, unless they are
        a sliver of anti-aliasing (see :data:`STRAY_SHARE`).
    name : str
        For messages.
    every_colour : bool
        Whether a style colour no pixel has is an error (a mistyped colour
        on the command line: its style would still set the run's cell and
        patch sizes).

    Returns
    -------
    ndarray of int16, shape (rows, cols)

    Raises
    ------
    SketchError
        No colours, a sizeable area in a colour no style names (the
        message names the colour and its share), or with ``every_colour``
        a style colour given twice or that paints nothing (the message
        names the image's colours).
    """
    palette = np.array([parse_colour(c) if isinstance(c, str) else tuple(int(v) for v in c) for c in colours],
                       dtype=np.float64)
    if palette.size == 0:
        raise SketchError(f"{name}: give at least one style colour")
    named = [colour_hex(p) for p in palette]
    rgb = rgba[..., :3].reshape(-1, 3).astype(np.float32)
    opaque = rgba[..., 3].reshape(-1) >= 128
    # One colour at a time: memory stays at a few arrays of the image's size.
    labels = np.zeros(rgb.shape[0], np.int16)
    nearest = np.full(rgb.shape[0], np.inf, np.float32)
    for i, colour in enumerate(palette):
        d = np.sqrt(((rgb - colour.astype(np.float32)) ** 2).sum(axis=1))
        closer = d < nearest
        labels[closer] = i
        nearest[closer] = d[closer]
    stray = (nearest > COLOUR_TOLERANCE) | ~opaque
    if stray.any():
        if default:
            labels[stray] = -1
        elif stray.mean() > STRAY_SHARE:
            values, counts = np.unique(rgb[stray & opaque].astype(np.uint8), axis=0, return_counts=True)
            if values.size:
                worst = colour_hex(values[np.argmax(counts)])
                what = f"colour {worst} ({100 * counts.max() / rgb.shape[0]:.1f} % of the pixels)"
            else:
                what = f"transparent pixels ({100 * (~opaque).mean():.1f} %)"
            raise SketchError(f"{name} holds {what} that no style is given for (styles: {', '.join(named)}): "
                              "add a --style for it or give a default --example")
    if every_colour:
        twice = sorted({c for c in named if named.count(c) > 1})
        if twice:
            raise SketchError(f"{name}: style colour {twice[0]} is given more than once")
        # (Only pixels of the colour count: a stray one kept its nearest label.)
        unpainted = np.flatnonzero(np.bincount(labels[~stray], minlength=len(palette)) == 0)
        if unpainted.size:
            raise SketchError(f"{name} has no pixel of style colour {named[unpainted[0]]}; "
                              f"its colours are {colour_shares(rgba)}")
    return labels.reshape(rgba.shape[:2])


def read_label_map(path, colours, *, default: bool = False, every_colour: bool = False) -> np.ndarray:
    """Read a style-region PNG (one flat colour per style).

    Parameters
    ----------
    path : str or Path
    colours : sequence of (r, g, b) or "#RRGGBB"
        Colour of style 0, 1, ...
    default, every_colour : bool
        See :func:`label_map_from_rgba`.

    Returns
    -------
    ndarray of int16, shape (rows, cols)
        Style index per pixel, -1 for the plain examples.
    """
    path = Path(path)
    return label_map_from_rgba(_read_rgba(path, "style map"), colours, default=default, name=f"style map {path}",
                               every_colour=every_colour)


def read_colour_shares(path) -> str:
    """:func:`colour_shares` of the style-region PNG at ``path``."""
    return colour_shares(_read_rgba(Path(path), "style map"))


def read_mask(path) -> np.ndarray:
    """Read a water mask: opaque pixels darker than mid-grey are water.

    Black, blue or any dark paint on a white (or transparent) ground works.

    Returns
    -------
    ndarray of bool, shape (rows, cols)
    """
    path = Path(path)
    rgba = _read_rgba(path, "water mask")
    luminance = rgba[..., :3].astype(np.float32) @ np.array([0.299, 0.587, 0.114], np.float32)
    return (luminance < 128) & (rgba[..., 3] >= 128)
