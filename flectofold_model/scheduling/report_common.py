"""What the day report and the annual report share: the predictive rows and the gaps.

:mod:`.day_report` judges one clear-sky day, :mod:`.annual_report` a weather file's dates;
both run the predictive controller a step at a time (:func:`predictive_desired`), name the
row of the controller the facade does not run (:data:`OTHER_ROW`) and measure each row's
gap to the limit (:func:`limit_gaps`).
"""

import math
from typing import Callable, Protocol, TYPE_CHECKING

from flectofold_model._validate import FloatArray
from flectofold_model.scheduling.facade_schedule import full_close_air_nl
from flectofold_model.scheduling.frontier import ClosureProblem, limit_at, Limits
from flectofold_model.scheduling.predictive import (PlanInputs, PredictiveController,
                                                    PredictiveParameters)
from flectofold_model.scheduling.scheduler import SchedulerParameters

if TYPE_CHECKING:  # the facade's module loads when used
    from flectofold_model.facade.description import Facade

#: The row of the controller the facade does not run, beside ``scheduled``.
OTHER_ROW = {'predictive': 'predictive', 'target': 'target rule'}


class Candidates(Protocol):
    """The candidate closures (K,) and their view fractions (K,): a shading table's."""

    @property
    def closures(self) -> FloatArray: ...

    @property
    def view(self) -> FloatArray: ...


class RowFigures(Protocol):
    """A row's blocked direct sun [kWh/m2] and view-weighted hours [h]."""

    @property
    def blocked_direct_kwh_m2(self) -> float: ...

    @property
    def view_weighted_hours_h(self) -> float: ...


def predictive_desired(facade: 'Facade', table: Candidates, inputs: PlanInputs, dni: FloatArray,
                       step_s: float, parameters: SchedulerParameters
                       ) -> Callable[[int, FloatArray], FloatArray]:
    """Make the predictive controller's decisions, one per step, from what is known then.

    The step's own DNI is the measurement (as the threshold rule and the target rule's DNI
    gate take it); the steps ahead are forecast from it (:mod:`.predictive`).
    """
    settings = PredictiveParameters.of(facade.control)
    controller = PredictiveController(table.closures, table.view, full_close_air_nl(facade),
                                      settings, deadband=parameters.deadband)
    horizon = settings.steps(step_s)

    def desired(i: int, closure_now: FloatArray) -> FloatArray:
        ahead = slice(i, i + horizon)
        window = PlanInputs(cos_incidence=inputs.cos_incidence[ahead],
                            blocked=inputs.blocked[ahead], daylight=inputs.daylight[ahead],
                            clear_dni_w_m2=inputs.clear_dni_w_m2[ahead],
                            step_h=inputs.step_h[ahead])
        return controller.desired(closure_now, window, dni_now_w_m2=dni[i])
    return desired


def limit_gaps(problem: ClosureProblem, limits: Limits,
               figures: RowFigures) -> tuple[float, ...]:
    """Return the gaps [h] with and without the scheduler's limits at ``figures``'s blocking.

    NaN where no schedule within them blocks as much.
    """
    gaps = []
    for bound in (limits, None):
        try:
            limit = limit_at(problem, figures.blocked_direct_kwh_m2, bound)
        except ValueError:
            gaps.append(math.nan)
            continue
        gaps.append(limit.view_weighted_upper_h - figures.view_weighted_hours_h)
    return tuple(gaps)
