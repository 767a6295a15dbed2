"""The reflection construction: fold planes, the crease, fold angles and flap tips.

Convention (Koerner et al. 2016, after Mitani & Igarashi 2011). The bent mid-rib S is a
cylinder over the elastica (generators along y). Each flap is the mirror image of S, extended
beyond the fold line, across the **three-point plane** through the displaced fold-line ends
C' and E (at the supports) and the displaced apex M' (mid-span). Both ends sit on the pin line
``z = 0`` at ``y = y_e``, the apex at ``(0, y_a, delta)``, so the plane holds the x direction
and tilts by ``alpha0 = atan(delta / h_c)`` about the line ``y = y_e, z = 0``, with ``delta``
the mid-rib sag and ``h_c = y_a - y_e`` the fold-line sag.

Consequences, all exact for the mesh this package builds:

* the apex fold angle (deviation from flat) is ``rho0 = 2 alpha0 = 2 atan(delta / h_c)``;
* along the crease ``rho(s) = 2 acos(cos(phi(s)) cos(alpha0))`` with ``phi`` the mid-rib slope,
  so the fold grows from the apex toward the supports;
* the crease S n P lies at ``y = y_e + h_c cn(lambda s | m)`` in the flat sheet: an elastica
  shape through the drawn arc's three points, not the arc itself. The gap to the drawn arc
  (:func:`crease_mismatch_m`) is what the real hinge zone absorbs.

The **local curvature law** ``tan(rho / 2) = kappa_n / kappa_g`` (Fuchs & Tabachnikov) instead
makes the reflection exact along the drawn arc, which needs a mid-rib whose curvature rises
toward the ends; an elastica (zero curvature at the pins) cannot do that. At the apex it gives
``2 atan(kappa0 R)`` (:func:`local_law_apex_fold_angle`), 15-25 % above the three-point angle.
The three-point plane is the one the paper uses, and the one this package uses throughout.
"""

import numpy as np
import numpy.typing as npt
from scipy.special import ellipk

from flectofold_model._validate import FloatArray, FloatOrArray
from flectofold_model.kinematics.elastica import elastica_shape
from flectofold_model.kinematics.panel import PanelBatch


def apex_fold_angle(batch: PanelBatch, sag_m: npt.ArrayLike) -> FloatArray:
    """Fold angle at the apex, ``2 atan(delta / h_c)`` [rad], for mid-rib sags [m]."""
    return 2.0 * np.arctan2(sag_m, batch.fold_line_sag_m)


def sag_for_apex_fold_angle(batch: PanelBatch, fold_angle_rad: FloatOrArray) -> FloatArray:
    """Mid-rib sag [m] that gives an apex fold angle [rad]; inverse of :func:`apex_fold_angle`."""
    return batch.fold_line_sag_m * np.tan(fold_angle_rad / 2.0)


def fold_plane(batch: PanelBatch, sag_m: npt.ArrayLike,
               side: int) -> tuple[FloatArray, FloatArray]:
    """Mirror plane of the flap on ``side`` (+1 for +y, -1 for -y) as ``(normal, offset)``.

    ``normal`` has shape ``(N, 3)``; points ``p`` on the plane satisfy ``normal . p = offset``.
    The plane holds the x direction and passes through the fold-line ends ``(x, +-y_e, 0)``
    and the apex ``(0, +-y_a, delta)``; its normal is ``(0, 0, 1)`` when unfolded.
    """
    sag_m = np.asarray(sag_m, dtype=np.float64)
    half_angle = np.arctan2(sag_m, batch.fold_line_sag_m)
    normal = np.stack([np.zeros_like(half_angle), -side * np.sin(half_angle),
                       np.cos(half_angle)], axis=-1)
    offset = -np.sin(half_angle) * batch.end_y_m
    return normal, offset


def reflect(points: FloatArray, normal: FloatArray, offset: FloatOrArray) -> FloatArray:
    """Mirror ``points`` (..., 3) across planes ``normal . p = offset`` (broadcasting)."""
    distance = np.einsum('...i,...i->...', points, normal) - offset
    return points - 2.0 * distance[..., None] * normal


def crease_flat_y(batch: PanelBatch, normalized_height: FloatArray) -> FloatArray:
    """Flat-sheet y of the +y crease at the stations where ``z / delta`` is given [m]."""
    return batch.end_y_m[..., None] + batch.fold_line_sag_m[..., None] * normalized_height


def drawn_fold_line_y(batch: PanelBatch, arc_length_m: npt.ArrayLike) -> FloatArray:
    """Flat-sheet y of the +y fold line as drawn (the circular arc) [m]."""
    radius = batch.fold_radius_m[..., None]
    return batch.apex_y_m[..., None] - radius + np.sqrt(radius**2 - np.square(arc_length_m))


def crease_stations(batch: PanelBatch, count: int) -> FloatArray:
    """``count`` arc lengths per panel, evenly from support to support, shape ``(N, count)``."""
    return batch.length_m[:, None] * np.linspace(-0.5, 0.5, count)


def crease_mismatch_m(batch: PanelBatch, k: npt.ArrayLike, count: int = 201) -> FloatArray:
    """Largest gap between the reflected crease and the drawn arc in the flat sheet [m]."""
    stations = crease_stations(batch, count)
    shape = elastica_shape(k, batch.length_m, stations)
    gap = crease_flat_y(batch, shape.normalized_height) - drawn_fold_line_y(batch, stations)
    return np.max(np.abs(gap), axis=-1)


def fold_angle_along_crease(batch: PanelBatch, k: npt.ArrayLike, sag_m: npt.ArrayLike,
                            arc_length_m: npt.ArrayLike) -> FloatArray:
    """Fold angle [rad] at crease stations ``s`` (from mid-span), shape ``(N, n)``."""
    shape = elastica_shape(k, batch.length_m, arc_length_m)
    half_angle = np.arctan2(sag_m, batch.fold_line_sag_m)[..., None]
    cosine = np.cos(shape.slope_rad) * np.cos(half_angle)
    return 2.0 * np.arccos(np.clip(cosine, -1.0, 1.0))


def local_law_apex_fold_angle(batch: PanelBatch, k: FloatOrArray) -> FloatArray:
    """Apex fold angle [rad] the local law ``2 atan(kappa0 R)`` would give (for comparison)."""
    peak_curvature = 4.0 * k * ellipk(np.square(k)) / batch.length_m
    return 2.0 * np.arctan(peak_curvature * batch.fold_radius_m)


def flap_tip(batch: PanelBatch, sag_m: npt.ArrayLike, side: int) -> FloatArray:
    """Position (N, 3) of flap tip A (side +1) or D (side -1): mid-span of the flap's edge.

    Before reflection the tip sits on the extended mid-rib at ``(0, +-W/2, delta)``.
    """
    sag_m = np.asarray(sag_m, dtype=np.float64)
    on_surface = np.stack([np.zeros_like(sag_m), np.broadcast_to(side * batch.width_m / 2,
                                                                 sag_m.shape), sag_m], axis=-1)
    normal, offset = fold_plane(batch, sag_m, side)
    return reflect(on_surface, normal, offset)
