"""The three drawn fold lines of a hexagonal panel: quadratic B-splines in the flat sheet.

Fold line ``i`` is the clamped quadratic B-spline with control points ``T_i``, ``Q_i``,
``T_(i+1)`` (a NURBS with unit weights; :class:`scipy.interpolate.BSpline`). ``Q_i`` sits on
the axis from the centre to the flap tip ``H_i``, at twice the fold line's sag beyond the
triangle edge, so the curve's apex (parameter 1/2) lies exactly ``fold_line_sag_m`` beyond
it. Sector angles count from ``T_i`` toward ``T_(i+1)`` as seen from the centre.
"""

import math

import numpy as np
import numpy.typing as npt
from scipy.interpolate import BSpline

from flectofold_model._validate import FloatArray
from flectofold_model.kinematics.hexagon_panel import HexagonBatch, SECTOR_RAD

_KNOTS = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0])


def control_points_m(batch: HexagonBatch) -> FloatArray:
    """Control points (N, 3, 2) of fold line 0 in a frame with T_0 on +y, ``Q`` on the left.

    The line is symmetric about its mid-azimuth (150 degrees); the other fold lines are it
    turned by 120 and 240 degrees.
    """
    radius = batch.circumradius_m
    start = np.stack([np.zeros_like(radius), radius], axis=-1)
    end = radius[:, None] * np.array([math.cos(7 * math.pi / 6), math.sin(7 * math.pi / 6)])
    mid_azimuth = math.pi / 2 + SECTOR_RAD / 2
    control = ((batch.edge_distance_m + 2 * batch.fold_line_sag_m)[:, None]
               * np.array([math.cos(mid_azimuth), math.sin(mid_azimuth)]))
    return np.stack([start, control, end], axis=1)


def fold_line_spline(batch: HexagonBatch) -> BSpline:
    """Fold line 0 of every panel as one :class:`~scipy.interpolate.BSpline`.

    Evaluated at parameters (P,) in [0, 1] it gives points (P, N, 2) [m]; its ``derivative()``
    the tangents.
    """
    return BSpline(_KNOTS, np.moveaxis(control_points_m(batch), 1, 0), 2)


def fold_line_points_m(batch: HexagonBatch, parameter: npt.ArrayLike) -> FloatArray:
    """Points (N, P, 2) of fold line 0 at B-spline parameters ``parameter`` (P,) in [0, 1]."""
    return np.moveaxis(fold_line_spline(batch)(np.asarray(parameter, dtype=np.float64)), 0, 1)


def drawn_radius_m(batch: HexagonBatch, sector_angle_rad: npt.ArrayLike,
                   samples: int = 401) -> FloatArray:
    """Distance from the centre to the drawn fold line [m] at sector angles (P,), (N, P).

    The spline is sampled densely and read back in polar form; its azimuth grows strictly
    along it, so the polar radius is a function of the sector angle.
    """
    points = fold_line_points_m(batch, np.linspace(0.0, 1.0, samples))
    angle = np.mod(np.arctan2(points[..., 1], points[..., 0]) - math.pi / 2, 2 * math.pi)
    radius = np.hypot(points[..., 0], points[..., 1])
    wanted = np.asarray(sector_angle_rad, dtype=np.float64)
    return np.stack([np.interp(wanted, a, r) for a, r in zip(angle, radius)])
