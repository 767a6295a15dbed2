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
from typing import Optional, Protocol

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, real_scalar


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


class Objective(Protocol):
    """What a planner asks of an objective (see the module doc)."""

    unit: str

    def rewards(self, stage: Stage) -> FloatArray:
        """(T, N, K) rewards of holding each candidate over each step, in :attr:`unit`."""
        ...


class SunAndView:
    """Blocked direct sun plus ``view_value_w_m2`` times the view, per step [Wh/m2].

    Parameters
    ----------
    view_value_w_m2 : float
        Value of an hour of full view in blocked direct sun [W/m2], ``>= 0``.
    """

    unit = 'Wh/m2'

    def __init__(self, view_value_w_m2: float) -> None:
        self.view_value_w_m2 = real_scalar('view_value_w_m2', view_value_w_m2)
        if self.view_value_w_m2 < 0.0:
            raise ValueError(f'view_value_w_m2 must not be negative, got '
                             f'{self.view_value_w_m2:g} W/m2')

    def rewards(self, stage: Stage) -> FloatArray:
        """(T, N, K) rewards of holding each candidate over each step [Wh/m2]."""
        step_h = np.asarray(stage.step_h, dtype=float)[:, None, None]
        view = (self.view_value_w_m2 * np.asarray(stage.view)[None, None, :]
                * np.asarray(stage.daylight)[:, None, None])
        return step_h * (stage.direct_w_m2[..., None] * stage.blocked + view)

    def __repr__(self) -> str:
        return f'SunAndView(view_value_w_m2={self.view_value_w_m2:g})'


class RoomAware:
    """Solar gain priced by what the room behind needs now, daylight, glare and view [Wh/m2].

    ``r = dt (m (E b(c) - E_d tau_d(c)) + lambda v(c) + [daytime] (delta s(c) - gamma
    g(c)))``: the direct sun the panel blocks, less the sky's diffuse light it lets through
    (``E_d`` the diffuse irradiance on the panel's plane, ``tau_d`` the diffuse transmittance
    of each candidate), weighted by the room's need ``m``: 1 while the room is being cooled
    (keep the sun out), ``-heating_value`` while it is heated (let the sun in),
    ``neutral_value`` otherwise (the sun let in now is cooling later); plus, when the room's
    daylight is known (:meth:`observe` with ``daylit`` and ``glare``), ``delta`` times the
    share ``s(c)`` of the work plane at 300 lx or more and minus ``gamma`` times ``g(c)``, 1
    where the eye's DGP would reach 0.40, at each candidate closure. The room's state is the
    building simulation's at the last step, held over the plan (persistence, the only thing
    known of the room ahead).

    Parameters
    ----------
    view_value_w_m2 : float
        Value of an hour of full view [W/m2], ``>= 0``.
    diffuse_transmittance : array-like
        (K,) diffuse transmittance of each candidate closure [-].
    heating_value, neutral_value : float
        The weights of solar gain while heating and with neither load, in [0, 1].
    daylight_value_w_m2, glare_value_w_m2 : float
        ``delta`` and ``gamma`` [W/m2], ``>= 0``: an hour of the whole work plane daylit is
        worth ``delta`` Wh/m2 of blocked sun, an hour of glare costs ``gamma``.
    """

    unit = 'Wh/m2'

    def __init__(self, view_value_w_m2: float, diffuse_transmittance: npt.ArrayLike,
                 heating_value: float = 0.5, neutral_value: float = 0.5,
                 daylight_value_w_m2: float = 0.0, glare_value_w_m2: float = 0.0) -> None:
        self.view = SunAndView(view_value_w_m2)
        self.diffuse_transmittance = np.asarray(diffuse_transmittance, dtype=float)
        for name, value in (('heating_value', heating_value),
                            ('neutral_value', neutral_value)):
            if not 0.0 <= real_scalar(name, value) <= 1.0:
                raise ValueError(f'{name} must lie in [0, 1], got {value:g}')
        for name, value in (('daylight_value_w_m2', daylight_value_w_m2),
                            ('glare_value_w_m2', glare_value_w_m2)):
            if not real_scalar(name, value) >= 0.0:
                raise ValueError(f'{name} must not be negative, got {value:g} W/m2')
        self.heating_value, self.neutral_value = float(heating_value), float(neutral_value)
        self.daylight_value_w_m2 = float(daylight_value_w_m2)
        self.glare_value_w_m2 = float(glare_value_w_m2)
        self.need = neutral_value
        self.diffuse_w_m2 = 0.0
        self.room_light = np.zeros_like(self.diffuse_transmittance)

    def observe(self, cooling_w: float, heating_w: float, diffuse_w_m2: float,
                daylit: Optional[npt.ArrayLike] = None,
                glare: Optional[npt.ArrayLike] = None) -> None:
        """Take the room's state of the last step.

        ``cooling_w``, ``heating_w`` its sensible cooling and heating rates [W];
        ``diffuse_w_m2`` the sky's diffuse irradiance on the facade [W/m2]; ``daylit`` and
        ``glare`` (K,) the share of the work plane at 300 lx or more and whether the eye's
        DGP reaches 0.40 at each candidate closure, now (``None``: not known, no term).
        """
        self.need = (1.0 if cooling_w > 0.0 else -self.heating_value if heating_w > 0.0
                     else self.neutral_value)
        self.diffuse_w_m2 = max(float(diffuse_w_m2), 0.0)
        light = np.zeros_like(self.diffuse_transmittance)
        for value, price, sign in ((daylit, self.daylight_value_w_m2, 1.0),
                                   (glare, self.glare_value_w_m2, -1.0)):
            if value is not None:
                value = np.asarray(value, dtype=float)
                if value.shape != light.shape or not np.all(np.isfinite(value)):
                    raise ValueError(f'daylit and glare must be {light.shape[0]} finite '
                                     f'values, one per candidate, got {value.shape}')
                light = light + sign * price * value
        self.room_light = light

    def rewards(self, stage: Stage) -> FloatArray:
        """(T, N, K) rewards of holding each candidate over each step [Wh/m2]."""
        step_h = np.asarray(stage.step_h, dtype=float)[:, None, None]
        gain = stage.direct_w_m2[..., None] * stage.blocked \
            - self.diffuse_w_m2 * self.diffuse_transmittance[None, None, :]
        daytime = np.asarray(stage.daylight)[:, None, None]
        view = self.view.view_value_w_m2 * np.asarray(stage.view)[None, None, :] * daytime
        return step_h * (self.need * gain + view + self.room_light[None, None, :] * daytime)
