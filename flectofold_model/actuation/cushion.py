"""The strip cushion between the back part and the mid-rib.

An inextensible flat tube of width ``W0`` pressed between two plates a gap ``h`` apart takes a
stadium cross-section: flat contact strips of width ``a = W0 - pi h / 2`` on both plates and
half-circular sides. Per unit length its cross-section area is ``A = W0 h - pi h**2 / 4`` and,
by virtual work, the force on each plate is ``p dA/dh = p a`` (the pouch-motor model, Niiyama
et al., Soft Robotics 2015). The stroke ends at ``h = 2 W0 / pi``, where the tube is round and
pushes no more.

In a Flectofold panel the tube lies along the middle of the mid-rib; the back part holds it
``mount_gap_m`` away from the mid-rib in the open state, so the gap at arc length ``s`` is
``h(s) = mount_gap_m + z(s) - z_open(s)`` with ``z`` the mid-rib's height over its pins.
"""

from dataclasses import dataclass
import math

import numpy as np

from flectofold_model._validate import FloatOrArray, real_fields


@dataclass(frozen=True)
class StripCushion:
    """Geometry of a strip cushion centred on the mid-rib."""

    flat_width_m: float
    """Width of the flat, empty tube [m]."""
    length_m: float
    """Length of the tube along the mid-rib [m]."""
    mount_gap_m: float = 0.005
    """Gap between back part and mid-rib at the cushion in the open state [m]."""

    def __post_init__(self) -> None:
        real_fields(self)
        for name in ('flat_width_m', 'length_m'):
            if getattr(self, name) <= 0.0:
                raise ValueError(f'{name} must be positive, got {getattr(self, name):g} m')
        if not 0.0 <= self.mount_gap_m < self.max_gap_m:
            raise ValueError(
                f'mount_gap_m must lie in [0, {self.max_gap_m:.4g}) m (the round tube of '
                f'flat_width_m={self.flat_width_m:g} m), got {self.mount_gap_m:g} m')

    @property
    def max_gap_m(self) -> float:
        """Gap at which the tube is round and its stroke ends [m]."""
        return 2.0 * self.flat_width_m / math.pi


def section_area_m2(flat_width_m: FloatOrArray, gap_m: FloatOrArray) -> FloatOrArray:
    """Cross-section area ``W0 h - pi h**2 / 4`` of the tube at gap ``h`` [m2]."""
    return flat_width_m * gap_m - math.pi * np.square(gap_m) / 4.0


def contact_width_m(flat_width_m: FloatOrArray, gap_m: FloatOrArray) -> FloatOrArray:
    """Width ``W0 - pi h / 2`` over which the pressure pushes on each plate [m]."""
    return flat_width_m - math.pi * gap_m / 2.0
