"""What the day report and the annual report share: the predictive rows and the gaps.

:mod:`.day_report` judges one clear-sky day, :mod:`.annual_report` a weather file's dates;
both run the predictive controller a step at a time (:func:`predictive_desired`), name the
row of the controller the facade does not run (:data:`OTHER_ROW`) and measure each row's
gap to the limit (:func:`limit_gaps`).
"""

import math

from flectofold_model.scheduling.facade_schedule import full_close_air_nl
from flectofold_model.scheduling.frontier import limit_at
from flectofold_model.scheduling.predictive import (PlanInputs, PredictiveController,
                                                    PredictiveParameters)

#: The row of the controller the facade does not run, beside ``scheduled``.
OTHER_ROW = {'predictive': 'predictive', 'target': 'target rule'}


def predictive_desired(facade, table, inputs, dni, step_s, parameters):
    """Make the predictive controller's decisions, one per step, from what is known then.

    The step's own DNI is the measurement (as the threshold rule and the target rule's DNI
    gate take it); the steps ahead are forecast from it (:mod:`.predictive`).
    """
    settings = PredictiveParameters.of(facade.control)
    controller = PredictiveController(table.closures, table.view, full_close_air_nl(facade),
                                      settings, deadband=parameters.deadband)
    horizon = settings.steps(step_s)

    def desired(i, closure_now):
        ahead = slice(i, i + horizon)
        window = PlanInputs(cos_incidence=inputs.cos_incidence[ahead],
                            blocked=inputs.blocked[ahead], daylight=inputs.daylight[ahead],
                            clear_dni_w_m2=inputs.clear_dni_w_m2[ahead],
                            step_h=inputs.step_h[ahead])
        return controller.desired(closure_now, window, dni_now_w_m2=dni[i])
    return desired


def limit_gaps(problem, limits, figures):
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
