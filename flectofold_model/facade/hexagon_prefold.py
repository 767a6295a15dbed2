"""The pre-fold a curved patch supplies to a hexagonal panel, the analogue of the quad rule.

A quad panel gets ``2 atan(kappa_x L**2 / (8 h_c))`` from its bent mid-rib (the reflection
law) and ``-kappa_y W / 4`` from flaps tilted by the cross-curvature
(:mod:`flectofold_model.facade.description`). A hexagonal panel of circumradius ``R`` and
fold-line sag ``s`` on a patch with signed normal curvatures ``kappa_i`` (convex positive)
along its three flap axes (centre to flap tip ``H_i``, across fold line ``i``) gets the same
two parts:

1. **Centre rise.** The three triangle vertices ``T_i`` lie ``R`` from the centre; a patch
   that curves by ``kappa`` along a spoke puts its vertex ``kappa R**2 / 2`` behind the
   tangent plane at the centre, so the centre stands

       d = (R**2 / 2) * (kappa_0 + kappa_1 + kappa_2) / 3

   in front of the plane through the three vertices (the triangle's centroid is the
   centre). The spokes point along the flap axes turned by 180 degrees, and a normal
   curvature is the same both ways, so the mean is over the flap axes; it is the mean
   curvature ``(k_1 + k_2) / 2`` (Euler's formula averaged over three directions 120 degrees
   apart). That rise is the actuation's own stroke, and the panel model turns it into an apex
   fold angle ``rho(d)`` by the reflection method
   (:class:`~flectofold_model.kinematics.hexagon_reflection.SectorGeometry`); a concave patch
   (``d < 0``) pushes the centre back and folds the flaps the other way, ``rho(-d) =
   -rho(d)`` (the mirror image). For small rises ``rho(d)`` is close to ``5 d / (3 s)``.
2. **Flap tilt.** Flap ``i`` reaches from the fold line's apex, ``r_a = R / 2 + s`` from the
   centre, to its tip at ``R``. The patch's slope changes by ``-kappa_i (R - r_a) / 2``
   between the fold line and the flap's middle: a concave cross-section lifts the flap toward
   closing, a convex one lowers it.

The three flaps share one pre-fold (the panel is three-fold symmetric), so the patch supplies
the least any flap gets:

    supplied = rho(d) + min_i(-kappa_i (R - r_a) / 2)

A dome (``k_1, k_2 > 0``) gives a rise and takes some back at every flap; a symmetric saddle
(``k_1 = -k_2``) gives no rise, and its flap along the convex direction loses; a plane gives
nothing. The mould supplies the rest as for quads.
"""

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray
from flectofold_model.kinematics.hexagon_closure import MAX_SPOKE_TILT_RAD
from flectofold_model.kinematics.hexagon_panel import HexagonBatch
from flectofold_model.kinematics.hexagon_reflection import SectorGeometry


def centre_rise_m(circumradius_m: npt.ArrayLike, curvature_flap_per_m: FloatArray) -> FloatArray:
    """Rise ``d`` (N,) of the centre over the triangle vertices' plane on the patch [m]."""
    radius = np.asarray(circumradius_m, dtype=float)
    return radius ** 2 / 2 * np.mean(curvature_flap_per_m, axis=-1)


def reflection_fold_rad(circumradius_m: npt.ArrayLike, fold_line_sag_m: npt.ArrayLike,
                        rise_m: npt.ArrayLike) -> FloatArray:
    """Apex fold angle (N,) of the panel model at centre rises ``rise_m`` (N,), odd in the rise.

    ``ValueError`` for a rise beyond the model's largest spoke tilt.
    """
    radius = np.asarray(circumradius_m, dtype=float)
    rise = np.asarray(rise_m, dtype=float)
    limit = radius * np.sin(MAX_SPOKE_TILT_RAD)
    if np.any(np.abs(rise) > limit):
        index = int(np.flatnonzero(np.abs(rise) > limit)[0])
        raise ValueError(f'cell {index}: the patch raises the centre {rise[index]:+.3f} m, '
                         f'beyond what a panel of circumradius {radius[index]:g} m can take '
                         f'({limit[index]:.3f} m); the surface is too curved for it')
    count = rise.shape[0]
    batch = HexagonBatch(circumradius_m=radius, fold_line_sag_m=np.broadcast_to(
        np.asarray(fold_line_sag_m, dtype=float), (count,)).copy(),
        hinge_width_m=np.zeros(count), prefold_rad=np.zeros(count),
        closed_clearance_m=np.zeros(count))
    return np.sign(rise) * SectorGeometry(batch, np.abs(rise)).apex_fold_angle_rad


def flap_tilt_rad(circumradius_m: npt.ArrayLike, fold_line_sag_m: npt.ArrayLike,
                  curvature_flap_per_m: npt.ArrayLike) -> FloatArray:
    """Tilt (N, 3) of each flap toward closing from the patch's cross-curvature [rad]."""
    radius = np.asarray(circumradius_m, dtype=float)[..., None]
    apex = radius / 2 + np.asarray(fold_line_sag_m, dtype=float)[..., None]
    return -np.asarray(curvature_flap_per_m, dtype=float) * (radius - apex) / 2


def surface_prefold_rad(circumradius_m: npt.ArrayLike, fold_line_sag_m: npt.ArrayLike,
                        curvature_flap_per_m: FloatArray) -> FloatArray:
    """Pre-fold (N,) each patch supplies: centre-rise fold plus the least flap tilt [rad]."""
    rise = centre_rise_m(circumradius_m, curvature_flap_per_m)
    tilt = flap_tilt_rad(circumradius_m, fold_line_sag_m, curvature_flap_per_m)
    return reflection_fold_rad(circumradius_m, fold_line_sag_m, rise) + tilt.min(axis=-1)
