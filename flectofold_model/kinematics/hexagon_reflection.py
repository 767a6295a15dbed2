"""Fold planes, crease, fold angles and flap tips of a hexagonal panel (the reflection method).

Flap ``i`` is the mirror image of the central cone, extended beyond fold line ``i``, across the
three-point plane through the displaced fold-line ends ``T_i'``, ``T_(i+1)'`` and the displaced
apex ``M_i'`` (Koerner et al. 2018, section 6, as for the quad panel). Every function here
works on sector 0 (flap 0, between ``T_0`` at 90 degrees and ``T_1`` at 210 degrees); the panel
has three-fold symmetry, so flaps 1 and 2 are flap 0 turned by 120 and 240 degrees about z.

The crease is where the cone meets the plane: on the ruling at sector angle ``phi`` it lies at
``rho_c = (offset - n . C') / (n . g(phi))`` from the centre. It passes exactly through
``T_i``, ``M_i`` and ``T_(i+1)``; between them it leaves the drawn B-spline by a little
(:func:`crease_mismatch_m`), which the hinge zone absorbs. The fold angle along the crease is
twice the angle between the cone's tangent plane and the mirror plane.
"""

import math

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, FloatOrArray
from flectofold_model.kinematics import hexagon_cone as cone
from flectofold_model.kinematics.hexagon_fold_lines import drawn_radius_m
from flectofold_model.kinematics.hexagon_panel import HexagonBatch, SECTOR_RAD

MID_SECTOR_RAD = SECTOR_RAD / 2


def centre_point(rise_m: npt.ArrayLike) -> FloatArray:
    """Displaced centre ``C'`` (N, 3) [m]."""
    rise_m = np.asarray(rise_m, dtype=np.float64)
    return np.stack([np.zeros_like(rise_m), np.zeros_like(rise_m), rise_m], axis=-1)


def plane_through(first: FloatArray, second: FloatArray,
                  third: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Plane ``(normal (N, 3), offset (N,))`` through three points, normal toward +z."""
    normal = np.cross(second - first, third - first)
    normal *= np.sign(normal[..., 2:3]) / np.linalg.norm(normal, axis=-1, keepdims=True)
    return normal, np.einsum('...i,...i->...', normal, first)


def reflect(points: FloatArray, normal: FloatArray, offset: FloatOrArray) -> FloatArray:
    """Mirror ``points`` (..., 3) across planes ``normal . p = offset`` (broadcasting)."""
    distance = np.einsum('...i,...i->...', points, normal) - offset
    return points - 2.0 * distance[..., None] * normal


class SectorGeometry:
    """Cone, fold plane and crease of sector 0 for every panel of a batch at rises ``d`` (N,)."""

    def __init__(self, batch: HexagonBatch, rise_m: npt.ArrayLike) -> None:
        self.batch = batch
        self.rise_m = np.asarray(rise_m, dtype=np.float64)
        self.tilt_rad = cone.spoke_tilt_rad(batch, self.rise_m)
        self.amplitude_rad = cone.cone_amplitude_rad(self.tilt_rad)
        self.centre = centre_point(self.rise_m)
        ends = self.on_cone(np.array([0.0, MID_SECTOR_RAD, SECTOR_RAD]),
                            np.stack([batch.circumradius_m, batch.apex_radius_m,
                                      batch.circumradius_m], axis=-1))
        self.normal, self.offset = plane_through(ends[:, 0], ends[:, 2], ends[:, 1])

    def directions(self, phi: FloatArray) -> FloatArray:
        """Return the unit rulings (N, P, 3) of the cone at sector angles (P,)."""
        return cone.ruling_direction(self.tilt_rad, self.amplitude_rad, phi)

    def on_cone(self, phi: FloatArray, radius_m: FloatArray) -> FloatArray:
        """Cone points (N, P, 3) at sector angles (P,) and distances from the apex (N, P)."""
        return self.centre[:, None, :] + radius_m[..., None] * self.directions(phi)

    def crease_radius_m(self, phi: FloatArray) -> FloatArray:
        """Distance of the crease from the centre along the rulings at ``phi`` (N, P) [m]."""
        height = self.offset - np.einsum('ni,ni->n', self.normal, self.centre)
        return height[:, None] / np.einsum('npi,ni->np', self.directions(phi), self.normal)

    def surface_normal(self, phi: FloatArray) -> FloatArray:
        """Return the unit front normals (N, P, 3) of the cone along the rulings at ``phi``."""
        normal = np.cross(self.directions(phi),
                          cone.ruling_direction_rate(self.tilt_rad, self.amplitude_rad, phi))
        return normal * (np.sign(normal[..., 2:3])
                         / np.linalg.norm(normal, axis=-1, keepdims=True))

    def fold_angle_rad(self, phi: FloatArray) -> FloatArray:
        """Fold angle (deviation from flat) along the crease at ``phi`` (N, P) [rad]."""
        cosine = np.abs(np.einsum('npi,ni->np', self.surface_normal(phi), self.normal))
        return 2.0 * np.arccos(np.clip(cosine, -1.0, 1.0))

    @property
    def apex_fold_angle_rad(self) -> FloatArray:
        """Fold angle at the apex ``M_0`` of the crease (N,) [rad]."""
        return self.fold_angle_rad(np.array([MID_SECTOR_RAD]))[:, 0]

    def flap_points(self, phi: FloatArray, radius_m: FloatArray) -> FloatArray:
        """Folded positions (N, P, 3) of flap-0 points given flat polar coordinates."""
        return reflect(self.on_cone(phi, radius_m), self.normal[:, None], self.offset[:, None])

    @property
    def flap_tip(self) -> FloatArray:
        """Folded flap tip ``H_0`` (N, 3) [m]."""
        return self.flap_points(np.array([MID_SECTOR_RAD]),
                                self.batch.circumradius_m[:, None])[:, 0]

    def crease_mismatch_m(self, count: int = 121) -> FloatArray:
        """Largest radial gap between the crease and the drawn fold line (N,) [m]."""
        phi = np.linspace(0.0, SECTOR_RAD, count)
        return np.max(np.abs(self.crease_radius_m(phi) - drawn_radius_m(self.batch, phi)),
                      axis=-1)


def rotation_about_z(angle_rad: float) -> FloatArray:
    """(3, 3) rotation matrix by ``angle_rad`` about z."""
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
