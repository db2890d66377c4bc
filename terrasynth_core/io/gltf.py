"""Binary glTF 2.0 (``.glb``) terrain meshes: positions, normals, texture coordinates, an optional texture.

The container is simple enough to write directly (a 12-byte header, a JSON
chunk, a binary chunk; Khronos glTF 2.0 specification, section 4.4), so no
library is needed to write it; the tests read every file back with trimesh.

glTF is Y-up, metres: a TerraSynth vertex ``(x east, y north, z up)``
becomes ``(x, z, -y)``, so north is -Z as in Blender's and Three.js's
default views; triangles stay counter-clockwise seen from above.  The
optional texture (a PNG, e.g. the height colours under the hillshade) is
stored inside the file and draped by texture coordinates through the
centres of its pixels.
"""

from __future__ import annotations

import io
import json
import struct
from typing import BinaryIO

import numpy as np
from PIL import Image

_GLB_MAGIC = b"glTF"
_JSON_CHUNK = 0x4E4F534A
_BIN_CHUNK = 0x004E4942
_FLOAT = 5126
_UINT32 = 5125
_ARRAY_BUFFER = 34962
_ELEMENT_ARRAY_BUFFER = 34963


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit normals at the vertices: the area-weighted mean of their faces' normals.

    Parameters
    ----------
    vertices : ndarray of float, shape (n, 3)
    faces : ndarray of int, shape (m, 3)
        Counter-clockwise seen from the side the normals point to.

    Returns
    -------
    ndarray of float32, shape (n, 3)
        (0, 0, 1) for a vertex on no face.
    """
    v = vertices.astype(np.float64)
    corners = v[faces]
    face_normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])  # length = 2 area
    normals = np.zeros_like(v)
    for k in range(3):
        np.add.at(normals, faces[:, k], face_normals)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.where(length > 0, normals / np.where(length > 0, length, 1), [0.0, 0.0, 1.0])
    return normals.astype(np.float32)


def write_glb(vertices: np.ndarray, faces: np.ndarray, fh: BinaryIO, *, uv: np.ndarray | None = None,
              texture: np.ndarray | None = None) -> None:
    """Write a terrain mesh as one binary glTF.

    Parameters
    ----------
    vertices : ndarray of float32, shape (n, 3)
        ``(x east, y north, z up)`` metres (as :func:`.mesh.mesh_arrays`).
    faces : ndarray of int, shape (m, 3)
        Counter-clockwise seen from above.
    fh : binary file
    uv : ndarray of float32, shape (n, 2), optional
        Texture coordinates (u right, v down), needed with ``texture``.
    texture : ndarray of uint8, shape (rows, cols, 3), optional
        Base colour, stored as PNG inside the file.
    """
    gl_vertices = np.ascontiguousarray(np.stack([vertices[:, 0], vertices[:, 2], -vertices[:, 1]], axis=1),
                                       dtype="<f4")
    normals = vertex_normals(gl_vertices, faces)
    blobs: list[bytes] = []
    views, accessors = [], []

    def add_view(data: bytes, target: int | None) -> int:
        offset = sum(len(b) for b in blobs)
        blobs.append(data + b"\0" * (-len(data) % 4))  # 4-byte alignment of every view
        view = {"buffer": 0, "byteOffset": offset, "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        views.append(view)
        return len(views) - 1

    def add_accessor(array: np.ndarray, kind: str, component: int, target: int, bounds: bool = False) -> int:
        accessor = {"bufferView": add_view(array.tobytes(), target), "componentType": component,
                    "count": int(array.shape[0]), "type": kind}
        if bounds:  # required for POSITION
            accessor["min"] = [float(v) for v in array.min(axis=0)]
            accessor["max"] = [float(v) for v in array.max(axis=0)]
        accessors.append(accessor)
        return len(accessors) - 1

    attributes = {
        "POSITION": add_accessor(gl_vertices, "VEC3", _FLOAT, _ARRAY_BUFFER, bounds=True),
        "NORMAL": add_accessor(np.ascontiguousarray(normals, dtype="<f4"), "VEC3", _FLOAT, _ARRAY_BUFFER),
    }
    if uv is not None:
        attributes["TEXCOORD_0"] = add_accessor(np.ascontiguousarray(uv, dtype="<f4"), "VEC2", _FLOAT,
                                                _ARRAY_BUFFER)
    indices = add_accessor(np.ascontiguousarray(faces.ravel(), dtype="<u4"), "SCALAR", _UINT32,
                           _ELEMENT_ARRAY_BUFFER)
    primitive = {"attributes": attributes, "indices": indices, "mode": 4, "material": 0}
    material = {"name": "terrain", "pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 1.0}}
    document = {
        "asset": {"version": "2.0", "generator": "TerraSynth"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "terrain"}],
        "meshes": [{"name": "terrain", "primitives": [primitive]}],
        "materials": [material],
    }
    if texture is not None:
        png = io.BytesIO()
        Image.fromarray(np.ascontiguousarray(texture, dtype=np.uint8)).save(png, format="PNG")
        image_view = add_view(png.getvalue(), None)
        document["images"] = [{"bufferView": image_view, "mimeType": "image/png"}]
        # Linear filtering with mipmaps, clamped at the edges (no wrap-around seam).
        document["samplers"] = [{"magFilter": 9729, "minFilter": 9987, "wrapS": 33071, "wrapT": 33071}]
        document["textures"] = [{"source": 0, "sampler": 0}]
        material["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0, "texCoord": 0}
    binary = b"".join(blobs)
    document["buffers"] = [{"byteLength": len(binary)}]
    document["bufferViews"] = views
    document["accessors"] = accessors
    text = json.dumps(document, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)  # the JSON chunk is padded with spaces
    total = 12 + 8 + len(text) + 8 + len(binary)
    fh.write(_GLB_MAGIC + struct.pack("<II", 2, total))
    fh.write(struct.pack("<II", len(text), _JSON_CHUNK) + text)
    fh.write(struct.pack("<II", len(binary), _BIN_CHUNK) + binary)
