"""The predictive controller: each panel's best closure plan over the hours ahead.

The plan is made again at every decision (receding-horizon model-predictive control).

At each decision the controller knows the sun's path ahead exactly (an ephemeris), the
direct normal irradiance (DNI) measured now, and nothing of the weather ahead but a forecast.
For every panel it plans one candidate closure per step of a horizon of ``horizon_s``, the
plan that maximises the objective (:mod:`.objective`; by default blocked direct sun plus
``view_value_w_m2`` times the view) less ``move_cost_wh_m2`` per move and
``air_price_wh_m2_per_nl`` per normal litre of air a closing move draws, by dynamic
programming over the candidates (:func:`~.paths.first_levels`); it commands the plan's first
step, and plans again at the next decision from wherever the panel then is [1]_. The
:class:`~.scheduler.Scheduler` then applies every limit as for any other strategy (faults,
storm, overrides, dwell, deadband, rate limit, daily cap, air bucket, parallel fills); the
controller replaces only the choice of the desired closure and, since direct sun under clouds
is worth little, the DNI gate.

Forecast: persistence of the clear-sky index [2]_, ``k = DNI / DNI_clear`` from the last
measurement taken with ``DNI_clear >= clear_sky_min_w_m2``, clipped to ``[0, 1.2]`` and
applied to the clear-sky DNI of every step ahead (pvlib's Ineichen model with its monthly
Linke turbidity climatology [3]_). The first step uses the measured DNI itself. The weather
ahead is never read.

Panels are planned independently (the objective separates by panel); the cost is
``O(H K^2)`` per panel for ``H`` steps and ``K`` candidates, compiled (measured by
``bench/bench_schedule.py``, results in ``bench/results/controller.md``).

References
----------
.. [1] Rawlings, J. B., Mayne, D. Q. and Diehl, M., "Model Predictive Control: Theory,
   Computation, and Design", 2nd ed., Nob Hill, 2017, ch. 1.
.. [2] Pedro, H. T. C. and Coimbra, C. F. M., "Assessment of forecasting techniques for solar
   power production with no exogenous inputs", Solar Energy 86(7) (2012) 2017-2028.
.. [3] Ineichen, P. and Perez, R., "A new airmass independent formulation for the Linke
   turbidity coefficient", Solar Energy 73(3) (2002) 151-157; pvlib.clearsky.ineichen.
"""

from dataclasses import dataclass, fields
import math
from typing import Any, Mapping, Optional, Protocol, Self, TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, real_array, real_scalar
from flectofold_model.scheduling.objective import Objective, Stage, SunAndView
from flectofold_model.scheduling.paths import first_levels
from flectofold_model.shading.ray_casting import SUNLIT_MIN_SZ

if TYPE_CHECKING:  # the table's module loads when used
    from flectofold_model.shading.table import ShadingTable


class PanelFrames(Protocol):
    """What the plan reads of a facade (:class:`~flectofold_model.facade.Facade`).

    A protocol, not the class: the facade's description imports this module to check its
    ``control`` section.
    """

    def sun_in_panel_frames(self, sun_enu: npt.ArrayLike) -> FloatArray:
        """Sun directions (..., 3) in ENU expressed in every panel frame: (..., N, 3)."""


#: The strategies the coordinator can run: ``control.controller`` of a facade.
CONTROLLERS = ('predictive', 'target')
#: The coordinator's controller when a facade names none.
DEFAULT_CONTROLLER = 'predictive'
#: The clear-sky index is clipped to this range [-].
CLEAR_SKY_INDEX_RANGE = (0.0, 1.2)


@dataclass(frozen=True)
class PredictiveParameters:
    """The predictive controller's prices and horizon; ``control`` keys of a facade.

    The defaults are one set for every climate; how they were chosen and what they give on
    three climates: ``msg_docs/controller.md``.
    """

    view_value_w_m2: float = 90.0
    """Value of an hour of full view, in direct sun blocked [W/m2]."""
    move_cost_wh_m2: float = 30.0
    """Price of one move of a panel [Wh/m2 of direct sun blocked]: wear (a cycle of the
    hinges) and noise."""
    air_price_wh_m2_per_nl: float = 0.5
    """Price of one normal litre of compressed air a closing move draws [Wh/m2 per NL]."""
    horizon_s: float = 21600.0
    """How far ahead each decision plans [s]."""
    plan_step_s: float = 900.0
    """Step of the coordinator's plan [s]; the annual report plans on its own step."""
    clear_sky_min_w_m2: float = 50.0
    """The clear-sky index is measured only while the clear-sky DNI reaches this [W/m2]."""

    def __post_init__(self) -> None:
        for field in fields(self):
            value = real_scalar(field.name, getattr(self, field.name))
            if value < 0.0:
                raise ValueError(f'{field.name} must not be negative, got {value:g}')
            object.__setattr__(self, field.name, value)
        for name in ('horizon_s', 'plan_step_s'):
            if getattr(self, name) <= 0.0:
                raise ValueError(f'{name} must be positive, got {getattr(self, name):g} s')
        if self.horizon_s > 7 * 86400.0:
            raise ValueError(f'horizon_s must be at most a week (604800 s), got '
                             f'{self.horizon_s:g} s')
        if self.horizon_s < self.plan_step_s:
            raise ValueError(f'horizon_s={self.horizon_s:g} s must be at least plan_step_s='
                             f'{self.plan_step_s:g} s')

    @classmethod
    def of(cls, control: Mapping[str, Any]) -> Self:
        """Make the parameters named in a facade's ``control`` section (others ignored)."""
        names = {f.name for f in fields(cls)}
        return cls(**{k: v for k, v in control.items() if k in names})

    def steps(self, step_s: float) -> int:
        """Return the steps of ``step_s`` in the horizon, at least 1."""
        return max(1, int(math.floor(self.horizon_s / step_s + 1e-9)))


@dataclass(frozen=True)
class PlanInputs:
    """What a decision sees of the ``H`` steps ahead, the first starting now."""

    cos_incidence: np.ndarray
    """(H, N) cosine of the sun's incidence on each panel, 0 where not sunlit [-]."""
    blocked: np.ndarray
    """(H, N, K) blocked fraction of each candidate at the step's sun (0 where not sunlit)."""
    daylight: np.ndarray
    """(H,) bool: the sun above the horizon."""
    clear_dni_w_m2: np.ndarray
    """(H,) clear-sky DNI of each step [W/m2]: a model, not a measurement."""
    step_h: np.ndarray
    """(H,) length of each step [h]."""


def plan_inputs(facade: PanelFrames, table: 'ShadingTable', sun_enu: npt.ArrayLike,
                clear_dni_w_m2: npt.ArrayLike, step_s: npt.ArrayLike) -> PlanInputs:
    """:class:`PlanInputs` from the sun vectors (H, 3) in ENU of the steps ahead.

    ``step_s`` scalar or (H,) [s]; the blocked fractions come from ``table``, as the
    coordinator's other strategies use it.
    """
    sun = np.asarray(sun_enu, dtype=float).reshape(-1, 3)
    in_panels = facade.sun_in_panel_frames(sun)
    above = sun[:, 2] > 0.0
    sunlit = (in_panels[..., 2] > SUNLIT_MIN_SZ) & above[:, None]
    blocked = table.blocked_fractions(in_panels.reshape(-1, 3)).reshape(
        in_panels.shape[:2] + (table.closures.size,)) * sunlit[..., None]
    steps = np.broadcast_to(np.asarray(step_s, dtype=float), above.shape)
    return PlanInputs(cos_incidence=np.where(sunlit, in_panels[..., 2], 0.0),
                      blocked=blocked, daylight=above,
                      clear_dni_w_m2=np.asarray(clear_dni_w_m2, dtype=float).reshape(-1),
                      step_h=steps / 3600.0)


class PredictiveController:
    """Desired closures of N panels by the receding-horizon plan; see the module doc.

    Parameters
    ----------
    closures : array-like
        (K,) candidate closures, increasing in [0, 1] (the shading table's).
    view : array-like
        (K,) view fraction of each candidate.
    air_nl : array-like
        (N,) free air of a full close of each panel [NL].
    parameters : PredictiveParameters
    deadband : float
        The scheduler's deadband [closure]: a change smaller than it is not a move.
    objective : object, optional
        Anything with ``rewards(stage)`` (:mod:`.objective`); default
        ``SunAndView(parameters.view_value_w_m2)``. Its unit is the unit of the prices.
    """

    def __init__(self, closures: npt.ArrayLike, view: npt.ArrayLike, air_nl: npt.ArrayLike,
                 parameters: PredictiveParameters = PredictiveParameters(),
                 deadband: float = 0.0, objective: Optional[Objective] = None) -> None:
        if not isinstance(parameters, PredictiveParameters):
            raise TypeError(f'parameters must be PredictiveParameters, got '
                            f'{type(parameters).__name__}')
        self.closures = real_array('closures', closures)
        self.view = real_array('view', view)
        if self.view.shape != self.closures.shape:
            raise ValueError('view and closures must have the same shape')
        self.air_nl = real_array('air_nl', air_nl).reshape(-1)
        self.parameters = parameters
        self.deadband = real_scalar('deadband', deadband)
        self.objective = SunAndView(parameters.view_value_w_m2) if objective is None \
            else objective
        count = self.air_nl.size
        self._move_cost = np.full(count, parameters.move_cost_wh_m2)
        self._air_price = parameters.air_price_wh_m2_per_nl * self.air_nl
        self.clear_sky_index = 1.0
        """The persisted clear-sky index: 1 until a first measurement."""

    def observe(self, dni_w_m2: float, clear_dni_w_m2: float) -> None:
        """Take a DNI measurement [W/m2] and the clear-sky DNI at its instant [W/m2]."""
        dni = real_scalar('dni_w_m2', dni_w_m2)
        clear = real_scalar('clear_dni_w_m2', clear_dni_w_m2)
        if dni >= 0.0 and clear >= max(self.parameters.clear_sky_min_w_m2, 1e-9):
            low, high = CLEAR_SKY_INDEX_RANGE
            self.clear_sky_index = min(max(dni / clear, low), high)

    def forecast_dni(self, inputs: PlanInputs, dni_now_w_m2: Optional[float] = None) -> FloatArray:
        """Return the DNI (H,) of the steps ahead [W/m2].

        The measurement now, then the persisted clear-sky index times the clear-sky DNI.
        """
        dni = self.clear_sky_index * inputs.clear_dni_w_m2
        if dni_now_w_m2 is not None:
            dni = dni.copy()
            dni[0] = dni_now_w_m2
        return dni

    def desired(self, closure_now: npt.ArrayLike, inputs: PlanInputs,
                dni_now_w_m2: Optional[float] = None) -> FloatArray:
        """Desired closure (N,) of each panel: the first step of its best plan.

        ``closure_now`` (N,) the commanded closures now; ``inputs`` a :class:`PlanInputs`;
        ``dni_now_w_m2`` the measured DNI (observed first), or None to forecast every step.
        """
        start = real_array('closure_now', closure_now).reshape(-1)
        if start.shape != self.air_nl.shape or inputs.blocked.shape[1] != start.size:
            raise ValueError(f'closure_now and the inputs must have one entry per panel '
                             f'({self.air_nl.size}), got {start.size} and '
                             f'{inputs.blocked.shape[1]}')
        if dni_now_w_m2 is not None:
            self.observe(dni_now_w_m2, inputs.clear_dni_w_m2[0])
        if not np.any(inputs.daylight):
            return start  # no daylight ahead: every reward is zero and every plan holds
        dni = self.forecast_dni(inputs, dni_now_w_m2)
        stage = Stage(direct_w_m2=dni[:, None] * inputs.cos_incidence, blocked=inputs.blocked,
                      view=self.view, daylight=inputs.daylight, step_h=inputs.step_h)
        rewards = np.ascontiguousarray(self.objective.rewards(stage), dtype=np.float64)
        levels = first_levels(rewards, self.closures, start, self._move_cost,
                              self._air_price, self.deadband)
        return self.closures[levels]
