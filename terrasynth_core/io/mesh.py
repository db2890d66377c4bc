"""Triangle meshes of a height field: Wavefront OBJ, binary STL, binary PLY.

Every valid grid node is a vertex at ``x = col * dx``, ``y = (rows - 1 -
row) * dy`` (north up, metres; 1 per cell when the cell size is unknown),
``z = height * vertical_scale``.  Each cell gives two triangles, wound
counter-clockwise seen from above so normals point up; triangles with a
nodata corner are left out.  Everything is built with whole-array numpy
operations, written in chunks to bound memory.
"""

from __future__ import annotations

import math
from typing import BinaryIO

import numpy as np

from ..errors import DEMFormatError, ParamsError
from ..heightfield import HeightField

#: Lines or triangles formatted per chunk (keeps temporary arrays to tens of MB).
CHUNK = 1 << 18

#: Significant digits of OBJ coordinates: float32 precision.
OBJ_DIGITS = 7

#: Vertex spacing (metres) of a field without a cell size.
DEFAULT_SPACING = 1.0

_STL_TRIANGLE = np.dtype([("normal", "<f4", (3,)), ("vertices", "<f4", (3, 3)), ("attribute", "<u2")])
_PLY_FACE = np.dtype([("count", "u1"), ("indices", "<i4", (3,))])


def mesh_arrays(
    field: HeightField, *, vertical_scale: float = 1.0, step: int = 1
) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of the surface of ``field``.

    Parameters
    ----------
    field : HeightField
    vertical_scale : float, default 1.0
        Factor on heights (vertical exaggeration); finite and positive.
    step : int, default 1
        Keep every ``step``-th row and column, to thin large grids.

    Returns
    -------
    vertices : ndarray of float32, shape (n_vertices, 3)
        ``(x, y, z)`` of the valid nodes in row-major order, metres.
    faces : ndarray of int32, shape (n_faces, 3)
        Vertex indices (0-based) of each triangle.

    Raises
    ------
    ParamsError
        Bad ``step`` or ``vertical_scale``, or a step leaving fewer than
        2 x 2 nodes.
    DEMFormatError
        No triangle has three valid corners.
    """
    if not (isinstance(step, (int, np.integer)) and step >= 1):
        raise ParamsError(f"step must be an integer >= 1, got {step!r}")
    if not (math.isfinite(vertical_scale) and vertical_scale > 0):
        raise ParamsError(f"vertical_scale must be finite and positive, got {vertical_scale!r}")
    heights = field.heights[::step, ::step]
    rows, cols = heights.shape
    if rows < 2 or cols < 2:
        raise ParamsError(f"step {step} leaves a {rows} x {cols} grid from {field.shape}; need at least 2 x 2")
    dy, dx = field.cell_size or (DEFAULT_SPACING, DEFAULT_SPACING)
    valid = ~np.isnan(heights)
    n_vertices = int(valid.sum())

    index = np.full(heights.shape, -1, dtype=np.int32)
    index[valid] = np.arange(n_vertices, dtype=np.int32)
    x = np.arange(cols) * (step * dx)
    y = (field.shape[0] - 1 - np.arange(rows) * step) * dy
    vertices = np.empty((n_vertices, 3), dtype=np.float32)
    vertices[:, 0] = np.broadcast_to(x, heights.shape)[valid]
    vertices[:, 1] = np.broadcast_to(y[:, None], heights.shape)[valid]
    vertices[:, 2] = heights[valid] * np.float32(vertical_scale)

    # Corners of each cell: a b on the northern edge, c d on the southern;
    # triangles (a, c, b) and (b, c, d) are counter-clockwise seen from above.
    a, b = index[:-1, :-1], index[:-1, 1:]
    c, d = index[1:, :-1], index[1:, 1:]
    faces = np.empty((rows - 1, cols - 1, 2, 3), dtype=np.int32)
    for k, corner in enumerate((a, c, b)):
        faces[:, :, 0, k] = corner
    for k, corner in enumerate((b, c, d)):
        faces[:, :, 1, k] = corner
    faces = faces.reshape(-1, 3)
    if n_vertices < valid.size:
        shared = (b >= 0) & (c >= 0)
        complete = np.stack([shared & (a >= 0), shared & (d >= 0)], axis=-1)
        faces = faces[complete.ravel()]
    if faces.size == 0:
        raise DEMFormatError(f"no triangle with three valid corners in the {rows} x {cols} grid")
    return vertices, faces


def decimate(vertices: np.ndarray, faces: np.ndarray, target_triangles: int) -> tuple[np.ndarray, np.ndarray]:
    """The mesh simplified to about ``target_triangles`` triangles.

    Quadric error metric edge collapses (Garland and Heckbert 1997, through
    pyfqmr, the Python binding of Fast Quadric Mesh Simplification): flat
    ground loses its vertices first, ridges and valleys keep theirs; the
    border is kept, so tiles still meet.  A mesh already at or under the
    target is returned as is.

    Parameters
    ----------
    vertices : ndarray of float32, shape (n, 3)
    faces : ndarray of int32, shape (m, 3)
    target_triangles : int
        At least 2.

    Returns
    -------
    vertices : ndarray of float32, shape (n', 3)
    faces : ndarray of int32, shape (m', 3)
        ``m'`` is about the target (more when the border alone needs more).
    """
    if not (isinstance(target_triangles, (int, np.integer)) and target_triangles >= 2):
        raise ParamsError(f"target triangle count must be a whole number >= 2, got {target_triangles!r}")
    if len(faces) <= target_triangles:
        return vertices, faces
    import pyfqmr

    simplifier = pyfqmr.Simplify()
    simplifier.setMesh(vertices.astype(np.float64), faces.astype(np.int32))
    simplifier.simplify_mesh(target_count=int(target_triangles), aggressiveness=7, preserve_border=True,
                             verbose=False)
    new_vertices, new_faces, _ = simplifier.getMesh()
    return new_vertices.astype(np.float32), new_faces.astype(np.int32)


def simplified_mesh(field: HeightField, target_triangles: int, *, vertical_scale: float = 1.0,
                    step: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """:func:`mesh_arrays` of ``field`` with about ``target_triangles`` triangles at most.

    :func:`decimate` first.  Quadric simplification stalls on exactly planar
    ground (every collapse costs nothing, so its numerical ties block it: a
    tilted plane of 100 x 100 nodes keeps 97 % of its triangles), so when it
    leaves more than 10 % over the target the grid is thinned instead: every
    ``k``-th row and column, ``k`` the smallest stride meeting the target.

    Returns
    -------
    vertices : ndarray of float32, shape (n, 3)
    faces : ndarray of int32, shape (m, 3)
    """
    vertices, faces = mesh_arrays(field, vertical_scale=vertical_scale, step=step)
    vertices, faces = decimate(vertices, faces, target_triangles)
    if len(faces) <= 1.1 * target_triangles:
        return vertices, faces
    rows, cols = field.shape
    stride = step
    while 2 * (-(-rows // stride) - 1) * (-(-cols // stride) - 1) > target_triangles and min(rows, cols) > 2 * stride:
        stride += 1
    return mesh_arrays(field, vertical_scale=vertical_scale, step=stride)


def texture_coordinates(vertices: np.ndarray, field: HeightField) -> np.ndarray:
    """Texture coordinates of mesh vertices over a picture of the whole grid.

    ``u`` runs west to east, ``v`` north to south, through the centres of
    the picture's pixels (one per cell of ``field``), so a picture of the
    same shape as the heightmap drapes cell for cell.

    Returns
    -------
    ndarray of float32, shape (n, 2)
    """
    rows, cols = field.shape
    dy, dx = field.cell_size or (DEFAULT_SPACING, DEFAULT_SPACING)
    u = (vertices[:, 0] / dx + 0.5) / cols
    v = ((rows - 1) - vertices[:, 1] / dy + 0.5) / rows
    return np.stack([u, v], axis=1).astype(np.float32)


def write_stl(vertices: np.ndarray, faces: np.ndarray, fh: BinaryIO) -> None:
    """Binary STL: 80-byte header, uint32 count, 50 bytes per triangle."""
    header = b"TerraSynth height field mesh".ljust(80, b" ")
    fh.write(header + np.uint32(len(faces)).astype("<u4").tobytes())
    for start in range(0, len(faces), CHUNK):
        corners = vertices[faces[start : start + CHUNK]]
        normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        length = np.linalg.norm(normal, axis=1, keepdims=True)
        records = np.zeros(len(corners), dtype=_STL_TRIANGLE)
        records["normal"] = normal / np.where(length > 0, length, 1)
        records["vertices"] = corners
        fh.write(records.tobytes())


def write_ply(vertices: np.ndarray, faces: np.ndarray, fh: BinaryIO) -> None:
    """Binary little-endian PLY with float x, y, z and int vertex_indices."""
    header = (
        "ply\n"
        "format binary_little_endian 1.0\n"
        "comment TerraSynth height field mesh\n"
        f"element vertex {len(vertices)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        f"element face {len(faces)}\n"
        "property list uchar int vertex_indices\n"
        "end_header\n"
    )
    fh.write(header.encode("ascii"))
    fh.write(vertices.astype("<f4").tobytes())
    for start in range(0, len(faces), CHUNK):
        chunk = faces[start : start + CHUNK]
        records = np.empty(len(chunk), dtype=_PLY_FACE)
        records["count"] = 3
        records["indices"] = chunk
        fh.write(records.tobytes())


def write_obj(vertices: np.ndarray, faces: np.ndarray, fh: BinaryIO) -> None:
    """Wavefront OBJ: ``v x y z`` lines then ``f i j k`` lines (1-based).

    Coordinates get :data:`OBJ_DIGITS` significant digits in fixed-point
    notation.  The text is built with numpy digit arithmetic on whole
    columns, because Python string formatting of the millions of lines of a
    large DEM takes tens of seconds.
    """
    fh.write(f"# TerraSynth height field mesh: {len(vertices)} vertices, {len(faces)} faces\n".encode())
    decimals = [_decimals_for(vertices[:, k]) for k in range(3)]
    for start in range(0, len(vertices), CHUNK):
        chunk = vertices[start : start + CHUNK].astype(np.float64)
        fields = [(chunk[:, k], decimals[k]) for k in range(3)]
        fh.write(_text_lines(b"v", fields))
    for start in range(0, len(faces), CHUNK):
        chunk = faces[start : start + CHUNK].astype(np.int64) + 1
        fh.write(_text_lines(b"f", [(chunk[:, k], 0) for k in range(3)]))


def _decimals_for(values: np.ndarray) -> int:
    """Decimals giving :data:`OBJ_DIGITS` significant digits at the largest magnitude."""
    largest = float(np.abs(values).max()) if len(values) else 0.0
    if largest < 1:
        return OBJ_DIGITS - 1
    return max(0, OBJ_DIGITS - len(str(int(largest))))


def _text_lines(keyword: bytes, fields: list[tuple[np.ndarray, int]]) -> bytes:
    """Lines ``keyword n1 n2 ...`` for each row of the ``fields`` columns.

    Parameters
    ----------
    keyword : bytes
        Start of every line.
    fields : list of (values, decimals)
        One column of numbers (shape (n,)) and the digits after the point to
        write (0 for integers).

    Notes
    -----
    The text is laid out in a fixed-width uint8 matrix with one *column* per
    line (so every character position is a contiguous row, fast to fill),
    with a boolean mask of the characters to keep: no leading zeros, a minus
    sign only where negative.  Transposing and masking gives the text.
    """
    n = len(fields[0][0])
    layout = []  # (scaled magnitudes, negative mask, integer digits, decimals)
    width = len(keyword) + 1  # keyword and the newline
    for values, decimals in fields:
        scaled = np.rint(np.abs(values) * 10.0**decimals).astype(np.int64)
        int_digits = len(str(int(scaled.max()) // 10**decimals))
        layout.append((scaled, values < 0, int_digits, decimals))
        width += 2 + int_digits + (decimals + 1 if decimals else 0)  # space, sign, digits

    chars = np.empty((width, n), dtype=np.uint8)
    keep = np.ones((width, n), dtype=bool)
    chars[: len(keyword)] = np.frombuffer(keyword, dtype=np.uint8)[:, None]
    row = len(keyword)
    for scaled, negative, int_digits, decimals in layout:
        chars[row] = ord(" ")
        chars[row + 1] = ord("-")
        keep[row + 1] = negative & (scaled > 0)
        row += 2
        digit_rows = list(range(row, row + int_digits))
        if decimals:
            chars[row + int_digits] = ord(".")
            digit_rows += list(range(row + int_digits + 1, row + int_digits + 1 + decimals))
        # Digits from the last one leftwards; int32 arithmetic is several
        # times faster where the values allow it.
        rest = scaled.astype(np.int32) if scaled.max() < 2**31 else scaled
        for digit_row in reversed(digit_rows):
            quotient = rest // 10
            chars[digit_row] = rest - quotient * 10 + ord("0")
            rest = quotient
        # Leading zeros of the integer part go, except the units digit.
        seen = np.zeros(n, dtype=bool)
        for digit_row in digit_rows[: int_digits - 1]:
            seen |= chars[digit_row] != ord("0")
            keep[digit_row] = seen
        row = digit_rows[-1] + 1
    chars[row] = ord("\n")
    return np.ascontiguousarray(chars.T)[np.ascontiguousarray(keep.T)].tobytes()
