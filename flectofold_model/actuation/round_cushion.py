"""The round cushion behind the central part of a hexagonal panel.

Two circular membranes of flat radius ``a0`` welded at their rim (a lay-flat pouch) lie
between the back part and the central part, centred under the centre point. The back part
follows the open panel's shape ``mount_gap_m`` behind it, so the gap at flat polar
coordinates ``(r, phi)`` of the central cone is ``h(r, phi) = h_c - s(phi) r`` with

* ``h_c = mount_gap_m + d - d_open`` the gap at the centre (``d`` the centre rise), and
* ``s(phi) = sin e_open(phi) - sin e(phi)`` how much steeper the ruling at ``phi`` falls
  than in the open state (``e`` the ruling's elevation).

Each azimuth of the pouch is the half of a strip cushion's section (:mod:`.cushion`, the
pouch-motor model of Niiyama et al., Soft Robotics 2015): the membranes lie on both plates out
to the contact radius ``a`` and are joined there by a half-circular rim of diameter
``h_a = h(a)``. The membranes do not stretch along a radius, so each keeps its flat radius,
``a + pi h_a / 4 = a0``, which gives ``a = (a0 - pi h_c / 4) / (1 - pi s / 4)``. The volume of
the wedge ``d phi`` is ``(h_c a**2 / 2 - s a**3 / 3 + pi h_a**2 / 8 (a + 2 h_a / (3 pi))) d phi``
(the rim by Pappus' theorem). The stroke ends when the contact disc shrinks to a point, at a
centre gap of ``4 a0 / pi`` between parallel plates; the hoop direction is left free to wrinkle.
"""

from dataclasses import dataclass
import math

import numpy as np

from flectofold_model._validate import FloatOrArray, real_fields


@dataclass(frozen=True)
class RoundCushion:
    """Geometry of a round pouch cushion centred under the centre point."""

    flat_radius_m: float
    """Radius of the flat, empty pouch [m]."""
    mount_gap_m: float = 0.005
    """Gap between back part and central part at the centre in the open state [m]."""

    def __post_init__(self) -> None:
        real_fields(self)
        if self.flat_radius_m <= 0.0:
            raise ValueError(f'flat_radius_m must be positive, got {self.flat_radius_m:g} m')
        if not 0.0 <= self.mount_gap_m < self.max_gap_m:
            raise ValueError(
                f'mount_gap_m must lie in [0, {self.max_gap_m:.4g}) m (the end of the stroke '
                f'of a pouch of flat_radius_m={self.flat_radius_m:g} m), got '
                f'{self.mount_gap_m:g} m')

    @property
    def max_gap_m(self) -> float:
        """Centre gap between parallel plates at which the contact disc vanishes [m]."""
        return 4.0 * self.flat_radius_m / math.pi

    @property
    def flat_area_m2(self) -> float:
        """Area of the flat pouch [m2]."""
        return math.pi * self.flat_radius_m ** 2


def contact_radius_m(flat_radius_m: FloatOrArray, centre_gap_m: FloatOrArray,
                     steepening: FloatOrArray) -> FloatOrArray:
    """Radius ``a`` out to which the pouch touches both plates [m], at least zero.

    ``centre_gap_m`` is ``h_c``, ``steepening`` the gap's fall per metre of radius ``s``.
    """
    radius = ((flat_radius_m - math.pi * centre_gap_m / 4.0)
              / (1.0 - math.pi * steepening / 4.0))
    return np.clip(radius, 0.0, flat_radius_m)


def wedge_volume_m3(flat_radius_m: FloatOrArray, centre_gap_m: FloatOrArray,
                    steepening: FloatOrArray) -> FloatOrArray:
    """Pouch volume per radian of azimuth [m3/rad] (see the module docstring)."""
    radius = contact_radius_m(flat_radius_m, centre_gap_m, steepening)
    rim = np.maximum(centre_gap_m - steepening * radius, 0.0)
    return (centre_gap_m * radius ** 2 / 2.0 - steepening * radius ** 3 / 3.0
            + math.pi * rim ** 2 / 8.0 * (radius + 2.0 * rim / (3.0 * math.pi)))
