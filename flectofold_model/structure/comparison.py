"""The structural path and the reflection model side by side, at the same closures.

Closure is the package's: ``(rho - rho_open) / (rho_closed - rho_open)`` of the apex fold
angle ``rho``, with ``rho_open`` the pre-fold and ``rho_closed`` the kinematic model's closed
limit (:mod:`~..kinematics.closure`). The structural path is read at the same apex fold
angles by linear interpolation between its equilibria; closures it did not reach are NaN.
"""

from dataclasses import dataclass
from typing import Optional, TYPE_CHECKING, Union

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray
from flectofold_model.actuation.kinds import actuation_model_of
from flectofold_model.actuation.strain import panel_strain

if TYPE_CHECKING:  # the structural path's module loads where a path is traced
    from flectofold_model.actuation.hexagon_statics import HexagonActuatedPanel
    from flectofold_model.actuation.statics import ActuatedPanel
    from flectofold_model.structure.panel import StructuralPath

#: An actuated panel of either kind.
Actuated = Union['ActuatedPanel', 'HexagonActuatedPanel']


@dataclass(frozen=True)
class ClosureRows:
    """One value per closure of each quantity; NaN where a model has none."""

    closure: np.ndarray
    """0 open ... 1 closed."""
    apex_fold_rad: np.ndarray
    """Apex fold angle of the closure [rad] (the same for both models)."""
    pressure_pa: np.ndarray
    """Cushion gauge pressure holding the closure [Pa]."""
    air_m3: np.ndarray
    """Cushion volume added since open [m3]."""
    tip_travel_m: np.ndarray
    """Distance flap tip A moved since open [m]."""
    hinge_strain: np.ndarray
    """Peak hinge surface strain."""
    midrib_strain: np.ndarray
    """Peak mid-rib surface strain."""
    flap_strain: np.ndarray
    """Peak flap surface strain."""
    support_fold_rad: Optional[np.ndarray] = None
    """Fold angle next to the supports [rad] (structural only)."""
    stable_at_pressure: Optional[np.ndarray] = None
    """Whether a pressure regulator holds the closure (structural only)."""


def closure_apex_folds_rad(actuated: Actuated, closures: npt.ArrayLike) -> FloatArray:
    """Apex fold angles [rad] of ``closures`` of one actuated panel (quad or hexagon).

    The package's closure is linear in the apex fold, from the pre-fold (0) to the kinematic
    model's closed fold (1).
    """
    fold = actuation_model_of([actuated]).fold
    opened = float(fold.open_fold_angle_rad[0])
    closed = float(fold.closed_fold_angle_rad[0])
    return opened + np.asarray(closures, dtype=np.float64) * (closed - opened)


def kinematic_rows(actuated: Actuated, closures: npt.ArrayLike) -> ClosureRows:
    """Read the reflection model with its energy statics at ``closures`` (quad or hexagon)."""
    closures = np.asarray(closures, dtype=np.float64)
    model = actuation_model_of([actuated] * len(closures))
    state = model.fold.state_from_closure(closures)
    strain = panel_strain([actuated] * len(closures), closures)
    air = (model.cushion_volume_m3(state.shape_parameter)
           - model.cushion_volume_m3(model.fold.open_shape))
    return ClosureRows(closures, state.apex_fold_angle_rad, model.pressure_from_closure(closures),
                       air, state.tip_travel_m, strain.hinge_strain, strain.midrib_strain,
                       strain.flap_strain)


def structural_rows(actuated: Actuated, path: 'StructuralPath',
                    closures: npt.ArrayLike) -> ClosureRows:
    """Read a :class:`~.panel.StructuralPath` at the closures of the kinematic map."""
    closures = np.asarray(closures, dtype=np.float64)
    target = closure_apex_folds_rad(actuated, closures)
    fold = np.asarray(path.apex_fold_rad)
    # The path up to its largest apex fold, where the fold rises along it.
    end = int(np.argmax(fold)) + 1
    rising = np.maximum.accumulate(fold[:end])

    def at(values: npt.ArrayLike) -> FloatArray:
        values = np.asarray(values, dtype=np.float64)[:end]
        result = np.interp(target, rising, values)
        return np.where((target >= rising[0] - 1e-9) & (target <= rising[-1] + 1e-9),
                        result, np.nan)

    stable = at(np.asarray(path.stable_at_pressure, dtype=np.float64))
    return ClosureRows(
        closures, target, at(path.pressure_pa), at(path.air_m3), at(path.tip_travel_m),
        at(path.peak_strain['hinge']), at(path.peak_strain['midrib']),
        at(path.peak_strain['flap']), at(path.support_fold_rad),
        np.where(np.isnan(stable), np.nan, stable >= 1.0))
