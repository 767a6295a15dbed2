"""Triangle meshes of folded hexagonal panels, computed for many panels at once.

Vertex layout (one topology for every panel): the centre point; then the central cone as
``3 m`` rulings (``m`` per sector, counter-clockwise from the spoke to ``T_0``) by ``rings``
vertices from the centre out to the crease; then the three flaps, each ``m + 1`` rulings by
``flap_columns`` vertices from the crease out to the hexagon's edge. The crease vertices are
duplicated between the cone and the flaps so each side keeps its own normal.

The cone is the polyhedral cone of :func:`~.hexagon_cone.discrete_ruling_directions`: consecutive
rulings make exactly their flat angle, so every triangle keeps its flat edge lengths
(:func:`flat_coordinates`) and the sectors close around the centre. The fold plane of each
flap is the plane through the mesh's own ``T_i'``, ``M_i'``, ``T_(i+1)'``, so the crease
vertices lie on it and each flap is the exact mirror image of the cone beyond them. At the
triangle vertices a flap narrows to a point; the faces that would have no area there are
left out.

Vertices are in the panel frame (origin at the hexagon's centre, z out of the facade) [m];
triangles wind counter-clockwise seen from the front, and the normals point out of it.
"""

from dataclasses import dataclass
import math
from typing import Optional

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, IntArray
from flectofold_model.kinematics import hexagon_cone as cone
from flectofold_model.kinematics.hexagon_panel import (hexagon_radius_m, HexagonBatch,
                                                       SECTOR_RAD)
from flectofold_model.kinematics.hexagon_reflection import (centre_point, plane_through, reflect,
                                                            rotation_about_z)
from flectofold_model.kinematics.mesh import check_counts, FoldMesh, output_arrays


@dataclass(frozen=True)
class HexagonTopology:
    """Resolution, vertex layout and faces of a hexagonal panel mesh."""

    rulings_per_sector: int
    rings: int
    flap_columns: int

    def __post_init__(self) -> None:
        check_counts(self, (('rulings_per_sector', 2), ('rings', 1), ('flap_columns', 2)))
        if self.rulings_per_sector % 2:
            raise ValueError(f'rulings_per_sector must be even (a ruling runs through each '
                             f'crease apex), got {self.rulings_per_sector}')

    @property
    def cone_vertex_count(self) -> int:
        """Vertices of the central cone, the centre point included."""
        return 1 + 3 * self.rulings_per_sector * self.rings

    @property
    def flap_vertex_count(self) -> int:
        """Vertices of one flap."""
        return (self.rulings_per_sector + 1) * self.flap_columns

    @property
    def vertex_count(self) -> int:
        """Vertices per panel."""
        return self.cone_vertex_count + 3 * self.flap_vertex_count

    def flap(self, index: int) -> slice:
        """Slice of the vertices of flap ``index`` (0, 1, 2)."""
        start = self.cone_vertex_count + index * self.flap_vertex_count
        return slice(start, start + self.flap_vertex_count)

    @property
    def flat_polar(self) -> tuple[FloatArray, FloatArray]:
        """Flat azimuth (V,) [rad] and fraction (V,) of every vertex's place on its ruling.

        For a cone vertex the fraction runs 0 (centre) to 1 (crease); for a flap vertex,
        0 (crease) to 1 (hexagon edge).
        """
        m, rings, columns = self.rulings_per_sector, self.rings, self.flap_columns
        azimuth = [np.zeros(1)]
        fraction = [np.zeros(1)]
        cone_azimuth = math.pi / 2 + np.arange(3 * m) * SECTOR_RAD / m
        azimuth.append(np.repeat(cone_azimuth, rings))
        fraction.append(np.tile(np.arange(1, rings + 1) / rings, 3 * m))
        for index in range(3):
            ruling = math.pi / 2 + index * SECTOR_RAD + np.linspace(0.0, SECTOR_RAD, m + 1)
            azimuth.append(np.repeat(ruling, columns))
            fraction.append(np.tile(np.linspace(0.0, 1.0, columns), m + 1))
        return np.concatenate(azimuth), np.concatenate(fraction)

    @property
    def faces(self) -> npt.NDArray[np.int32]:
        """(F, 3) int32 triangle indices of one panel, counter-clockwise from the front."""
        m, rings, columns = self.rulings_per_sector, self.rings, self.flap_columns
        ring = 1 + np.arange(3 * m * rings).reshape(3 * m, rings)
        following = np.roll(ring, -1, axis=0)
        faces = [np.stack([np.zeros(3 * m, dtype=np.intp), ring[:, 0], following[:, 0]], -1)]
        if rings > 1:
            faces += _quads(ring[:, :-1], ring[:, 1:], following[:, 1:], following[:, :-1])
        for index in range(3):
            grid = self.flap(index).start + np.arange(self.flap_vertex_count).reshape(
                m + 1, columns)
            a, b = grid[:-1, :-1], grid[:-1, 1:]
            c, d = grid[1:, 1:], grid[1:, :-1]
            first = np.stack([a, b, c], -1)[1:].reshape(-1, 3)
            second = np.stack([a, c, d], -1)[:-1].reshape(-1, 3)
            faces += [first, second]
        return np.concatenate([f.reshape(-1, 3) for f in faces]).astype(np.int32)


def _quads(a: IntArray, b: IntArray, c: IntArray, d: IntArray) -> list[IntArray]:
    return [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]


#: A resolution for display: 12 rulings per sector, 4 rings, 8 flap columns (457 vertices).
DEFAULT_HEXAGON_TOPOLOGY = HexagonTopology(rulings_per_sector=12, rings=4, flap_columns=8)


def _sector_frame(
        batch: HexagonBatch, rise_m: FloatArray, topology: HexagonTopology,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Ruling directions of sector 0 (N, m+1, 3), its fold plane and crease radii (N, m+1)."""
    m = topology.rulings_per_sector
    directions = cone.discrete_ruling_directions(cone.spoke_tilt_rad(batch, rise_m), m)
    centre = centre_point(rise_m)
    radius = batch.circumradius_m[:, None]
    key = centre[:, None, :] + directions[:, [0, m // 2, m], :] * np.concatenate(
        [radius, batch.apex_radius_m[:, None], radius], axis=-1)[..., None]
    normal, offset = plane_through(key[:, 0], key[:, 2], key[:, 1])
    height = offset - np.einsum('ni,ni->n', normal, centre)
    crease = height[:, None] / np.einsum('npi,ni->np', directions, normal)
    crease[:, [0, m]] = radius
    crease[:, m // 2] = batch.apex_radius_m
    return directions, centre, normal, offset, crease


def _ruling_normals(directions: FloatArray) -> FloatArray:
    """Front normals (N, m+1, 3) of the polyhedral cone at its rulings (central differences)."""
    turned = directions @ rotation_about_z(SECTOR_RAD).T
    before = np.concatenate([(directions @ rotation_about_z(-SECTOR_RAD).T)[:, -2:-1],
                             directions[:, :-1]], axis=1)
    after = np.concatenate([directions[:, 1:], turned[:, 1:2]], axis=1)
    normal = np.cross(before, after)
    return normal / np.linalg.norm(normal, axis=-1, keepdims=True)


def hexagon_mesh(batch: HexagonBatch, rise_m: npt.ArrayLike,
                 topology: HexagonTopology = DEFAULT_HEXAGON_TOPOLOGY,
                 dtype: npt.DTypeLike = np.float64, out: Optional[FoldMesh] = None) -> FoldMesh:
    """Folded meshes of every panel of ``batch`` at centre rises ``rise_m`` (N,) [m]."""
    if not isinstance(batch, HexagonBatch):
        raise TypeError(f'hexagon_mesh needs a HexagonBatch, got {type(batch).__name__}')
    if not isinstance(topology, HexagonTopology):
        raise TypeError(f'topology must be a HexagonTopology, got {type(topology).__name__}')
    rise_m = np.broadcast_to(np.asarray(rise_m, dtype=np.float64), (len(batch),))
    shape = (len(batch), topology.vertex_count, 3)
    vertices, normals = output_arrays(out, shape, dtype)
    m, rings, columns = topology.rulings_per_sector, topology.rings, topology.flap_columns
    directions, centre, plane_normal, offset, crease = _sector_frame(batch, rise_m, topology)
    front = _ruling_normals(directions)
    phi = np.linspace(0.0, SECTOR_RAD, m + 1)
    edge = hexagon_radius_m(batch.circumradius_m[:, None], phi)
    ring_radius = crease[:, :m, None] * (np.arange(1, rings + 1) / rings)
    cone_points = centre[:, None, None] + ring_radius[..., None] * directions[:, :m, None]
    flap_radius = crease[..., None] + (edge - crease)[..., None] * np.linspace(0, 1, columns)
    flap_points = reflect(centre[:, None, None] + flap_radius[..., None] * directions[:, :, None],
                          plane_normal[:, None, None], offset[:, None, None])
    along = np.sum(front * plane_normal[:, None], axis=-1, keepdims=True)
    flap_front = 2 * along * plane_normal[:, None] - front
    vertices[:, 0] = centre
    normals[:, 0] = (0.0, 0.0, 1.0)
    for index in range(3):
        turn = rotation_about_z(index * SECTOR_RAD).T
        cone_block = slice(1 + index * m * rings, 1 + (index + 1) * m * rings)
        vertices[:, cone_block] = (cone_points @ turn).reshape(len(batch), -1, 3)
        normals[:, cone_block] = np.repeat(front[:, :m] @ turn, rings, axis=1)
        vertices[:, topology.flap(index)] = (flap_points @ turn).reshape(len(batch), -1, 3)
        normals[:, topology.flap(index)] = np.repeat(flap_front @ turn, columns, axis=1)
    return FoldMesh(vertices=vertices, normals=normals, faces=topology.faces)


def flat_coordinates(batch: HexagonBatch, rise_m: npt.ArrayLike,
                     topology: HexagonTopology = DEFAULT_HEXAGON_TOPOLOGY) -> FloatArray:
    """(N, V, 2) coordinates of every vertex in the unfolded sheet [m].

    The crease vertices follow the crease, which depends on the state ``rise_m``.
    """
    rise_m = np.broadcast_to(np.asarray(rise_m, dtype=np.float64), (len(batch),))
    m = topology.rulings_per_sector
    crease = _sector_frame(batch, rise_m, topology)[-1]
    azimuth, fraction = topology.flat_polar
    phi = np.mod(azimuth - math.pi / 2, SECTOR_RAD)
    on_spoke_end = np.zeros(azimuth.shape, dtype=bool)
    flaps = slice(topology.cone_vertex_count, None)
    ruling = np.rint(phi / (SECTOR_RAD / m)).astype(np.intp)
    on_spoke_end[flaps] = np.tile(np.repeat(np.arange(m + 1) == m, topology.flap_columns), 3)
    ruling = np.where(on_spoke_end, m, ruling)
    crease_here = crease[:, ruling]
    edge = hexagon_radius_m(batch.circumradius_m[:, None], np.where(on_spoke_end, SECTOR_RAD,
                                                                    phi))
    radius = np.where(np.arange(azimuth.size) < topology.cone_vertex_count,
                      crease_here * fraction, crease_here + (edge - crease_here) * fraction)
    return np.stack([radius * np.cos(azimuth), radius * np.sin(azimuth)], axis=-1)
