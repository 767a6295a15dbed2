"""Where a panel process's simulated loop starts its periods (``loop_start_s``).

The ticks are due a whole number of control periods apart; the loop's period ends must fall
midway between two due instants, whenever the first tick actually ran, or a process whose
first tick came late publishes its states at 0 and 200 ms intervals (``msg_docs/panel_node.md``).
"""

import numpy as np
import pytest

from flectofold_model.control.decimation import loop_start_s

PERIOD_S = 0.1


@pytest.mark.parametrize('late_s', [0.0, 0.001, 0.02, 0.048, 0.05, 0.07, 0.099])
def test_period_ends_fall_midway_between_due_ticks_however_late_the_first_tick(late_s):
    due_s = 1000.0  # the first tick was due here and ran late_s later
    start = loop_start_s(due_s + late_s, PERIOD_S - late_s, PERIOD_S)
    period_ends = start + PERIOD_S * np.arange(1, 50)
    offsets = (period_ends - due_s) % PERIOD_S  # where each end lies between two due ticks
    assert offsets == pytest.approx(0.5 * PERIOD_S, abs=1e-9)
    assert start <= due_s + late_s  # never in the future


def test_without_the_timer_s_schedule_the_tick_itself_is_taken_as_due():
    assert loop_start_s(50.0, None, PERIOD_S) == pytest.approx(50.0 - 0.5 * PERIOD_S)
    assert loop_start_s(50.0, 5.0, PERIOD_S) == pytest.approx(50.0 - 0.5 * PERIOD_S)
