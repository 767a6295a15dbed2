"""Panel meshes to CAD files: Wavefront OBJ and glTF 2.0 (``.gltf`` or binary ``.glb``).

Frames and units, the same for every file written here:

- **OBJ** of folded panels: the site frame ``site_enu`` as it is (x east, y north, z up),
  metres; one ``o <panel id>`` object per panel. OBJ has no unit or up axis of its own; the
  header comment says both.
- **glTF**: the format is right-handed with +Y up and metres [1], so a site point ``(E, N, U)``
  is written as ``(E, U, -N)`` (:func:`enu_to_gltf`): x east, y up, z south. A glTF
  importer that turns Y-up into Z-up (Blender's does, ``(x, y, z) -> (x, -z, y)``) gives
  back ``(E, N, U)``. One node and one mesh per panel, both named by its panel id.
- **OBJ of surface quads** (:func:`write_quad_obj`): the facade frame (``e1`` right seen
  from outside, ``e2`` up, ``e3`` out), metres: what ``surface: {type: obj}`` reads.

References
----------
.. [1] The Khronos Group, "glTF 2.0 Specification", section 3.4 "Coordinate System and
   Units": right-handed, +Y up, +Z forward (the front of an asset faces +Z), metres
   (``docs/references.md`` §10).
"""

from pathlib import Path
from typing import Any, Iterable, Sequence

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, IntArray, PathLike
from flectofold_model.facade.folded_mesh import PanelMesh

#: File suffixes :func:`write_meshes` knows, lower case.
MESH_SUFFIXES = ('.obj', '.gltf', '.glb')
#: glTF's component types and buffer-view targets used here (glTF 2.0, 5.1.3 and 5.11.4).
_FLOAT, _UNSIGNED_INT = 5126, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
#: The rotation from the site frame (E, N, U) to glTF's axes (x, y, z) = (E, U, -N).
ENU_TO_GLTF = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def enu_to_gltf(points_enu: npt.ArrayLike) -> FloatArray:
    """Site points (..., 3) (east, north, up) [m] in glTF's Y-up axes: (east, up, -north)."""
    return np.asarray(points_enu, dtype=float) @ ENU_TO_GLTF.T


def mesh_format(path: PathLike) -> str:
    """Return ``'obj'``, ``'gltf'`` or ``'glb'`` for a path; ``ValueError`` for another suffix."""
    suffix = Path(path).suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise ValueError(f'{path}: unknown suffix {suffix or "(none)"!r}: the export writes '
                         f'{", ".join(MESH_SUFFIXES)}')
    return suffix[1:]


def write_meshes(meshes: Sequence[PanelMesh], path: PathLike,
                 comments: Iterable[str] = ()) -> Path:
    """Write :class:`~.folded_mesh.PanelMesh` es to ``path`` in the format of its suffix.

    ``comments`` are lines for the OBJ header (glTF: ``asset.extras.comments``). Returns
    the path. Raises ``ValueError`` for an unknown suffix, ``OSError`` where it cannot write.
    """
    kind = mesh_format(path)
    if kind == 'obj':
        return write_obj(meshes, path, comments)
    return write_gltf(meshes, path, comments)


def write_obj(meshes: Sequence[PanelMesh], path: PathLike, comments: Iterable[str] = ()) -> Path:
    """Write the panels as OBJ objects in the site frame (vertices to the micrometre)."""
    lines = [f'# {line}' for line in comments]
    lines += ['# frame: site_enu, x east, y north, z up; units: metres',
              f'# {len(meshes)} panels, one object (o) per panel named by its panel id']
    base = 1
    for mesh in meshes:
        lines.append(f'o {mesh.panel_id}')
        lines.extend(f'v {x:.6f} {y:.6f} {z:.6f}'
                     for x, y, z in np.round(mesh.vertices_m, 6) + 0.0)
        lines.extend(f'f {a} {b} {c}' for a, b, c in mesh.faces + base)
        base += len(mesh.vertices_m)
    Path(path).write_text('\n'.join(lines) + '\n')
    return Path(path)


def write_gltf(meshes: Sequence[PanelMesh], path: PathLike,
               comments: Iterable[str] = ()) -> Path:
    """Write the panels as glTF 2.0 (one node and mesh per panel), Y-up: see the module doc.

    ``.glb`` is the binary container; ``.gltf`` is JSON with the buffer embedded as a
    base64 data URI (one self-contained file).
    """
    import pygltflib as gl
    blob = bytearray()
    views: list[Any] = []
    accessors: list[Any] = []
    nodes: list[Any] = []
    gltf_meshes: list[Any] = []
    for mesh in meshes:
        positions = enu_to_gltf(mesh.vertices_m).astype(np.float32)
        indices = np.asarray(mesh.faces, dtype=np.uint32).reshape(-1)
        position_accessor = _add(blob, views, accessors, positions, _ARRAY_BUFFER, _FLOAT,
                                 'VEC3', len(positions))
        accessors[-1].min = positions.min(axis=0).tolist()
        accessors[-1].max = positions.max(axis=0).tolist()
        index_accessor = _add(blob, views, accessors, indices, _ELEMENT_ARRAY_BUFFER,
                              _UNSIGNED_INT, 'SCALAR', len(indices))
        primitive = gl.Primitive(attributes=gl.Attributes(POSITION=position_accessor),
                                 indices=index_accessor, mode=gl.TRIANGLES)
        gltf_meshes.append(gl.Mesh(name=mesh.panel_id, primitives=[primitive]))
        nodes.append(gl.Node(name=mesh.panel_id, mesh=len(gltf_meshes) - 1))
    document = gl.GLTF2(
        asset=gl.Asset(generator='flectofold facade_export', version='2.0',
                       extras={'frame': 'glTF Y-up: x east, y up, z south (= -north)',
                               'units': 'm', 'comments': list(comments)}),
        scene=0, scenes=[gl.Scene(name='facade', nodes=list(range(len(nodes))))],
        nodes=nodes, meshes=gltf_meshes, accessors=accessors, bufferViews=views,
        buffers=[gl.Buffer(byteLength=len(blob))])
    document.set_binary_blob(bytes(blob))
    if mesh_format(path) == 'glb':
        document.save_binary(str(path))
    else:
        document.convert_buffers(gl.BufferFormat.DATAURI)
        document.save_json(str(path))
    return Path(path)


def _add(blob: bytearray, views: list[Any], accessors: list[Any], array: npt.NDArray[Any],
         target: int, component: int, kind: str, count: int) -> int:
    """Append ``array``'s bytes (4-byte aligned) as a buffer view and an accessor of it."""
    import pygltflib as gl
    blob.extend(b'\0' * (-len(blob) % 4))
    views.append(gl.BufferView(buffer=0, byteOffset=len(blob), byteLength=array.nbytes,
                               target=target))
    blob.extend(array.tobytes())
    accessors.append(gl.Accessor(bufferView=len(views) - 1, componentType=component,
                                 count=count, type=kind))
    return len(accessors) - 1


def write_quad_obj(vertices_m: FloatArray, quads: IntArray, path: PathLike,
                   comments: Iterable[str] = ()) -> Path:
    """Write a quad mesh (facade frame, metres) as OBJ, one ``f`` of four corners per quad."""
    lines = [f'# {line}' for line in comments]
    lines += ['# frame: facade frame, x along the facade (right seen from outside), y up, '
              'z out of the facade; units: metres',
              f'# {len(quads)} quads, one panel each (surface: {{type: obj}} reads this)']
    lines.extend(f'v {x:.9f} {y:.9f} {z:.9f}' for x, y, z in np.round(vertices_m, 9) + 0.0)
    lines.extend('f ' + ' '.join(str(i + 1) for i in quad) for quad in np.asarray(quads))
    Path(path).write_text('\n'.join(lines) + '\n')
    return Path(path)
