"""What the fold models of both panel kinds share: closure linear in the apex fold angle.

``closure = (rho0 - rho_open) / (rho_closed - rho_open)``: 0 open (the unactuated panel,
holding only its pre-fold), 1 closed.
"""

from typing import Any

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, in_range, real_array

#: Closure a computed fold angle may miss its interval by (root finders' rounding).
CLOSURE_ROUNDING = 1e-9


class LinearClosureMap:
    """Mixin of a fold model with ``batch``, ``open_fold_angle_rad``, ``closed_fold_angle_rad``.

    Its construction also sets ``crease_mismatch_m`` (N,) and calls :meth:`_check_hinges`.
    """

    #: The crease and what to change when a hinge cannot absorb its mismatch (for messages).
    crease_name = 'crease'
    hinge_remedy = 'widen the hinge zone'
    # What the fold model sets (for the type checker).
    batch: Any
    open_fold_angle_rad: FloatArray
    closed_fold_angle_rad: FloatArray
    crease_mismatch_m: FloatArray

    def __len__(self) -> int:
        return len(self.batch)

    def _check_hinges(self) -> None:
        too_narrow = self.crease_mismatch_m > self.batch.hinge_width_m
        if np.any(too_narrow):
            index = int(np.flatnonzero(too_narrow)[0])
            raise ValueError(
                f'panel {index}: hinge_width_m={self.batch.hinge_width_m[index]:g} m cannot '
                f'absorb the {self.crease_mismatch_m[index] * 1e3:.1f} mm by which the '
                f'{self.crease_name} leaves the drawn fold line; {self.hinge_remedy}')

    def _per_panel(self, name: str, value: npt.ArrayLike) -> FloatArray:
        array = real_array(name, value)
        try:
            return np.broadcast_to(array, (len(self),))
        except ValueError:
            raise ValueError(f'{name} has shape {array.shape}; expected a scalar or '
                             f'({len(self)},) for {len(self)} panels') from None

    def fold_angle_from_closure(self, closure: npt.ArrayLike) -> FloatArray:
        """Apex fold angle [rad] for closure in [0, 1]."""
        closure = in_range('closure', self._per_panel('closure', closure), 0.0, 1.0)
        return self.open_fold_angle_rad + closure * (self.closed_fold_angle_rad
                                                     - self.open_fold_angle_rad)

    def closure_from_fold_angle(self, fold_angle_rad: npt.ArrayLike) -> FloatArray:
        """Closure for apex fold angles [rad] between the open and closed limits.

        A fold angle within :data:`CLOSURE_ROUNDING` (in closure) outside them is the limit.
        """
        fold_angle_rad = self._per_panel('fold_angle_rad', fold_angle_rad)
        closure = ((fold_angle_rad - self.open_fold_angle_rad)
                   / (self.closed_fold_angle_rad - self.open_fold_angle_rad))
        in_range('closure for fold_angle_rad', closure, -CLOSURE_ROUNDING,
                 1.0 + CLOSURE_ROUNDING)
        return np.clip(closure, 0.0, 1.0)
