"""What a shading controller maximises: rewards per step, panel and candidate closure.

A controller that plans (:mod:`.predictive`) and the clairvoyant limit (:mod:`.frontier`)
both ask an objective for the reward of holding each candidate closure over each step,
``(T, N, K)``, from a :class:`Stage`: the steps' direct sun on each panel, the blocked
fraction of each candidate, the candidates' view fractions and whether it is daytime.
Objectives are interchangeable: anything with a ``rewards(stage)`` method that returns a
``(T, N, K)`` float array in one unit (the move and air costs of the planner are in that
unit too) and a ``unit`` attribute naming it.

:class:`SunAndView`, the default, prices the two things the annual report measures: the
direct sun the panel blocks and the view it gives,

``r = dt (E b(c) + lambda v(c) [daytime])``  [Wh/m2],

``E`` the direct irradiance on the panel's plane [W/m2], ``b(c)`` the blocked fraction and
``v(c)`` the view fraction at closure ``c``, ``dt`` in hours and ``lambda`` the **value of
view** [W/m2]: a panel gives up an hour of full view only to block more than ``lambda`` Wh/m2
of direct sun. Maximising the sum over a year for every ``lambda`` traces the supported
points of the blocking-view frontier (Everett [1]_): each is a best trade-off no schedule can
beat on both counts.

References
----------
.. [1] Everett, H., "Generalized Lagrange multiplier method for solving problems of optimum
   allocation of resources", Operations Research 11(3) (1963) 399-417.
"""

from dataclasses import dataclass

import numpy as np

from flectofold_model._validate import real_scalar


@dataclass(frozen=True)
class Stage:
    """The inputs of an objective over ``T`` steps of ``N`` panels and ``K`` candidates."""

    direct_w_m2: np.ndarray
    """(T, N) direct irradiance on each panel's plane, 0 where not sunlit [W/m2]."""
    blocked: np.ndarray
    """(T, N, K) blocked fraction of that direct sun at each candidate closure [-]."""
    view: np.ndarray
    """(K,) view fraction of each candidate closure [-]."""
    daylight: np.ndarray
    """(T,) bool: the sun is above the horizon (view counts only then)."""
    step_h: np.ndarray
    """(T,) length of each step [h]."""


class SunAndView:
    """Blocked direct sun plus ``view_value_w_m2`` times the view, per step [Wh/m2].

    Parameters
    ----------
    view_value_w_m2 : float
        Value of an hour of full view in blocked direct sun [W/m2], ``>= 0``.
    """

    unit = 'Wh/m2'

    def __init__(self, view_value_w_m2):
        self.view_value_w_m2 = real_scalar('view_value_w_m2', view_value_w_m2)
        if self.view_value_w_m2 < 0.0:
            raise ValueError(f'view_value_w_m2 must not be negative, got '
                             f'{self.view_value_w_m2:g} W/m2')

    def rewards(self, stage):
        """(T, N, K) rewards of holding each candidate over each step [Wh/m2]."""
        step_h = np.asarray(stage.step_h, dtype=float)[:, None, None]
        view = (self.view_value_w_m2 * np.asarray(stage.view)[None, None, :]
                * np.asarray(stage.daylight)[:, None, None])
        return step_h * (stage.direct_w_m2[..., None] * stage.blocked + view)

    def __repr__(self):
        return f'SunAndView(view_value_w_m2={self.view_value_w_m2:g})'
