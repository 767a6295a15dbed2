"""Validated description of a hexagonal Flectofold panel, singly and as a batch.

The flat panel is a regular hexagon of circumradius ``circumradius_m`` in the panel frame:
origin at its centre, z out of the facade, corners at the azimuths 30 + 60 j degrees (a
corner points along +y). Inside it stands the paper's triangle (Koerner et al. 2018, section
6, after Vergauwen et al. 2014): its vertices ``T_i`` are the alternate corners at
90 + 120 i degrees, so its three vertices are coplanar and its edges are the straight
stand-ins of the three fold lines. The other corners ``H_i`` (150 + 120 i degrees) are the
flap tips: flap ``i`` is the part of the sheet beyond fold line ``i``, which runs from ``T_i``
to ``T_(i+1)``.

Each fold line is a quadratic B-spline (a clamped NURBS with unit weights) with control
points ``T_i``, ``Q_i`` and ``T_(i+1)``; ``Q_i`` lies on the axis from the triangle's centre to
the flap tip ``H_i``, so the one length ``fold_line_sag_m`` (the apex's distance from the
straight edge, outward) sets the fold line's curvature, as the paper's extra control point
on the vertex-centre axis does. The central part, inside the three fold lines, is the
actuated part: the cushion behind it moves its centre point along the triangle's normal.
"""

from dataclasses import dataclass
import math

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, FloatOrArray, real_fields
from flectofold_model.kinematics.batch import PanelArrays

#: Azimuth of triangle vertex T_0 [rad]; T_i and flap tip H_i follow every 120 degrees.
FIRST_VERTEX_AZIMUTH_RAD = math.pi / 2
#: Angle each fold line spans as seen from the centre [rad].
SECTOR_RAD = 2 * math.pi / 3


@dataclass(frozen=True)
class HexagonPanel:
    """One hexagonal panel; construction checks that the geometry can exist and fold."""

    circumradius_m: float
    """Centre to corner of the regular hexagon, equal to its side length [m]."""
    fold_line_sag_m: float
    """Distance of each fold line's apex from the triangle edge it replaces, outward [m]."""
    hinge_width_m: float
    """Width of the flexible hinge zone along each fold line [m]."""
    prefold_rad: float
    """Apex fold angle the panel keeps when unactuated, toward closing [rad]."""
    closed_clearance_m: float = 0.02
    """Gap left between the three flap tips at full closure [m]."""

    def __post_init__(self) -> None:
        real_fields(self)
        for name in ('circumradius_m', 'fold_line_sag_m', 'hinge_width_m'):
            if getattr(self, name) <= 0.0:
                raise ValueError(f'{name} must be positive, got {getattr(self, name):g} m')
        if self.closed_clearance_m < 0.0:
            raise ValueError(
                f'closed_clearance_m must not be negative, got {self.closed_clearance_m:g} m')
        if not 0.0 < self.prefold_rad < math.pi / 2:
            raise ValueError(
                f'prefold_rad must lie in (0, pi/2): the reflection planes of a hexagonal '
                f'panel are defined only once its centre has left the flat, got '
                f'{self.prefold_rad:g} rad')
        room = self.circumradius_m / 2
        if self.fold_line_sag_m + self.hinge_width_m >= room:
            raise ValueError(
                f'fold_line_sag_m={self.fold_line_sag_m:g} m plus hinge_width_m='
                f'{self.hinge_width_m:g} m leaves no flap: the triangle edge is only '
                f'{room:.4g} m from the flap tip')
        if self.closed_clearance_m >= self.circumradius_m:
            raise ValueError(f'closed_clearance_m={self.closed_clearance_m:g} m is wider than '
                             f'the panel ({self.circumradius_m:g} m circumradius)')

    @property
    def area_m2(self) -> float:
        """Area of the flat hexagon [m2]."""
        return 1.5 * math.sqrt(3.0) * self.circumradius_m ** 2

    @property
    def across_flats_m(self) -> float:
        """Distance between opposite sides [m]."""
        return math.sqrt(3.0) * self.circumradius_m


@dataclass(frozen=True)
class HexagonBatch(PanelArrays):
    """Many hexagonal panels as arrays of shape ``(N,)``."""

    panel_class = HexagonPanel

    circumradius_m: np.ndarray
    fold_line_sag_m: np.ndarray
    hinge_width_m: np.ndarray
    prefold_rad: np.ndarray
    closed_clearance_m: np.ndarray

    @property
    def edge_distance_m(self) -> FloatArray:
        """Distance of each triangle edge from the centre, ``R / 2`` [m]."""
        return self.circumradius_m / 2

    @property
    def apex_radius_m(self) -> FloatArray:
        """Distance of each fold line's apex from the centre [m]."""
        return self.circumradius_m / 2 + self.fold_line_sag_m


def vertex_azimuths_rad() -> FloatArray:
    """Azimuths of the triangle vertices T_0, T_1, T_2 [rad], shape ``(3,)``."""
    return FIRST_VERTEX_AZIMUTH_RAD + SECTOR_RAD * np.arange(3, dtype=np.float64)


def hexagon_radius_m(circumradius_m: FloatOrArray, sector_angle_rad: npt.ArrayLike) -> FloatArray:
    """Distance from the centre to the hexagon's boundary [m] at an angle from a T vertex.

    ``sector_angle_rad`` runs 0 ... 2 pi / 3 across one flap; the boundary there is the two
    sides T_i H_i and H_i T_(i+1). Broadcasts ``(N, 1)`` against ``(..., P)``.
    """
    from_side_normal = np.abs(np.mod(sector_angle_rad, math.pi / 3) - math.pi / 6)
    return circumradius_m * (math.sqrt(3.0) / 2) / np.cos(from_side_normal)


#: A hexagonal module of the same area as the quad demonstrator's (about 1 m2). Sag, hinge and
#: pre-fold follow the quad module's proportions; the paper gives no dimensions.
HEXAGON_MODULE = HexagonPanel(circumradius_m=0.62, fold_line_sag_m=0.06, hinge_width_m=0.03,
                              prefold_rad=math.radians(5.0))
