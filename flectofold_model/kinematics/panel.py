"""Validated description of a Flectofold panel, singly and as a batch of many panels.

The flat panel is a rectangle ``length_m`` x ``width_m`` in the panel frame: x along the
mid-rib, y across it, z out of the facade, origin at the panel centre. The mid-rib is the
lens between two circular fold lines of radius ``fold_radius_m``; each arc passes through the
mid-rib's apex at ``y = +-midrib_width_m / 2`` and meets the supports B, C (``x = +-L/2``)
at ``y = +-(midrib_width_m / 2 - h_c)``, where ``h_c = R - sqrt(R**2 - L**2 / 4)`` is the
sag of the arc. The flaps are the rest of the sheet beyond the fold lines.
"""

from dataclasses import dataclass
import math
from typing import Any, overload, Self

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, real_fields, real_scalar
from flectofold_model.kinematics.batch import PanelArrays


@dataclass(frozen=True)
class PanelGeometry:
    """One Flectofold panel; construction checks that the geometry can exist and fold."""

    length_m: float
    """Mid-rib length between the supports B and C (the panel's length) [m]."""
    width_m: float
    """Panel width across the mid-rib, flap edge to flap edge [m]."""
    fold_radius_m: float
    """Radius of the two curved fold lines in the flat sheet [m]."""
    midrib_width_m: float
    """Width of the lens-shaped mid-rib at its apex (mid-span) [m]."""
    hinge_width_m: float
    """Width of the flexible hinge zone along each fold line [m]."""
    prefold_rad: float = 0.0
    """Fold angle the panel keeps when unactuated, toward closing [rad]."""
    closed_clearance_m: float = 0.02
    """Gap left between the two flap edges at full closure [m]."""

    def __post_init__(self) -> None:
        real_fields(self)
        self._check_signs()
        self._check_fold_lines()
        self._check_flaps()

    def _check_signs(self) -> None:
        for name in ('length_m', 'width_m', 'fold_radius_m', 'midrib_width_m', 'hinge_width_m'):
            if getattr(self, name) <= 0.0:
                raise ValueError(f'{name} must be positive, got {getattr(self, name):g} m')
        if self.closed_clearance_m < 0.0:
            raise ValueError(
                f'closed_clearance_m must not be negative, got {self.closed_clearance_m:g} m')
        if not 0.0 <= self.prefold_rad < math.pi / 2:
            raise ValueError(
                f'prefold_rad must lie in [0, pi/2) so the panel folds toward closing, '
                f'got {self.prefold_rad:g} rad')

    def _check_fold_lines(self) -> None:
        half_length = self.length_m / 2
        if self.fold_radius_m <= half_length:
            raise ValueError(
                f'fold_radius_m={self.fold_radius_m:g} m cannot span the mid-rib: a circular '
                f'fold line through both supports needs a radius above length_m/2 = '
                f'{half_length:g} m')
        lens_width = 2 * self.fold_line_sag_m
        if self.midrib_width_m <= lens_width:
            raise ValueError(
                f'midrib_width_m={self.midrib_width_m:g} m is too narrow for fold_radius_m='
                f'{self.fold_radius_m:g} m: the two fold-line arcs span {lens_width:.4g} m and '
                f'would cross before the supports; give more than that')

    def _check_flaps(self) -> None:
        needed = self.midrib_width_m + 2 * self.hinge_width_m
        if needed >= self.width_m:
            raise ValueError(
                f'width_m={self.width_m:g} m leaves no flap: the mid-rib plus both hinge zones '
                f'already take {needed:.4g} m')
        if self.closed_clearance_m >= self.width_m - self.midrib_width_m:
            raise ValueError(
                f'closed_clearance_m={self.closed_clearance_m:g} m is wider than the flaps can '
                f'close ({self.width_m - self.midrib_width_m:.4g} m)')

    @property
    def fold_line_sag_m(self) -> float:
        """Sag ``h_c`` of each fold-line arc over the mid-rib length [m]."""
        return fold_line_sag(self.fold_radius_m, self.length_m)

    @property
    def midrib_end_width_m(self) -> float:
        """Width of the mid-rib at the supports B and C [m]."""
        return self.midrib_width_m - 2 * self.fold_line_sag_m

    @property
    def flap_width_m(self) -> float:
        """Width of each flap at mid-span, fold line to edge [m]."""
        return (self.width_m - self.midrib_width_m) / 2

    @classmethod
    def with_lens_midrib(cls, length_m: float, width_m: float, fold_radius_m: float,
                         end_width_m: float, hinge_width_m: float,
                         **kwargs: float) -> Self:
        """Build a panel whose mid-rib width follows from the fold radius.

        The fold-line arcs meet the supports ``end_width_m`` apart, so the mid-rib is
        ``end_width_m + 2 h_c`` wide at its apex: a smaller radius gives a wider mid-rib.
        """
        sag = fold_line_sag(real_scalar('fold_radius_m', fold_radius_m),
                            real_scalar('length_m', length_m))
        if not math.isfinite(sag):
            raise ValueError(f'fold_radius_m={fold_radius_m:g} m cannot span length_m='
                             f'{length_m:g} m: it must exceed length_m/2')
        return cls(length_m=length_m, width_m=width_m, fold_radius_m=fold_radius_m,
                   midrib_width_m=real_scalar('end_width_m', end_width_m) + 2 * sag,
                   hinge_width_m=hinge_width_m, **kwargs)


@overload
def fold_line_sag(radius_m: float, chord_m: float) -> float: ...


@overload
def fold_line_sag(radius_m: FloatArray, chord_m: npt.ArrayLike) -> FloatArray: ...


def fold_line_sag(radius_m: npt.ArrayLike, chord_m: npt.ArrayLike) -> Any:
    """Sag of a circular arc of ``radius_m`` over ``chord_m`` [m]; NaN if it cannot span it."""
    radicand = np.square(radius_m) - np.square(chord_m) / 4
    with np.errstate(invalid='ignore'):
        return radius_m - np.sqrt(np.where(radicand >= 0, radicand, np.nan))


#: The first Flectofold prototype: a 520 mm x 420 mm GFRP rectangle (Koerner et al. 2016).
#: The fold radius (750 mm, the middle of the paper's study), mid-rib tip width, hinge width
#: and pre-fold are estimates: the paper's values were not published.
PROTOTYPE = PanelGeometry.with_lens_midrib(
    length_m=0.52, width_m=0.42, fold_radius_m=0.75, end_width_m=0.02, hinge_width_m=0.015,
    prefold_rad=math.radians(5.0))

#: A module of the 6 x 6 demonstrator (BauBionik, Stuttgart 2017-18): about 1 m2 each.
#: The outline is square here; radius, tips, hinge and pre-fold are estimates.
DEMONSTRATOR_MODULE = PanelGeometry.with_lens_midrib(
    length_m=1.0, width_m=1.0, fold_radius_m=1.0, end_width_m=0.04, hinge_width_m=0.03,
    prefold_rad=math.radians(5.0))


@dataclass(frozen=True)
class PanelBatch(PanelArrays):
    """Many panels as arrays of shape ``(N,)``: the form every vectorised function takes."""

    panel_class = PanelGeometry

    length_m: np.ndarray
    width_m: np.ndarray
    fold_radius_m: np.ndarray
    midrib_width_m: np.ndarray
    hinge_width_m: np.ndarray
    prefold_rad: np.ndarray
    closed_clearance_m: np.ndarray

    @property
    def fold_line_sag_m(self) -> FloatArray:
        """``h_c`` per panel [m]."""
        return fold_line_sag(self.fold_radius_m, self.length_m)

    @property
    def apex_y_m(self) -> FloatArray:
        """Distance of the fold lines from the axis at mid-span (the apex M) [m]."""
        return self.midrib_width_m / 2

    @property
    def end_y_m(self) -> FloatArray:
        """Distance of the fold lines from the axis at the supports [m]."""
        return self.midrib_width_m / 2 - self.fold_line_sag_m
