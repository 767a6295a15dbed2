"""Which states a loop keeps and a node publishes: the rate comes out as asked."""

import numpy as np
import pytest

from flectofold_model.control import PublishDecimator

#: A summer afternoon in POSIX seconds: float64 resolves only 2.4e-7 s here.
NOON_S = 1782036000.0


def loop_times(start_s, period_s, count):
    """Clock readings as a loop accumulates them: a sum of periods, rounding and all."""
    times, clock = [], start_s
    for _ in range(count):
        clock += period_s
        times.append(clock)
    return np.array(times)


@pytest.mark.parametrize('rate_hz', [1.0, 2.0, 5.0, 10.0, 3.0, 0.3])
def test_kept_states_come_at_the_asked_rate_at_day_scale_times(rate_hz):
    times = loop_times(NOON_S, 0.1, 600)  # one minute of a 10 Hz loop
    decimator = PublishDecimator(1.0 / rate_hz, slack_s=0.05)
    kept = times[[decimator.due(t) for t in times]]
    assert len(kept) == pytest.approx(60.0 * rate_hz, abs=1)
    if rate_hz in (1.0, 2.0, 5.0, 10.0):  # a whole number of loop periods: exactly even
        np.testing.assert_allclose(np.diff(kept), 1.0 / rate_hz, atol=1e-6)


def test_a_rate_that_is_no_whole_number_of_periods_stays_on_its_grid():
    times = loop_times(0.0, 0.1, 3000)
    decimator = PublishDecimator(1.0 / 3.0, slack_s=0.05)
    kept = times[[decimator.due(t) for t in times]]
    # 0.3 or 0.4 s apart, never drifting: the k-th state is within a period of k/3 s.
    assert set(np.round(np.diff(kept), 6)) == {0.3, 0.4}
    np.testing.assert_array_less(np.abs(kept - kept[0] - np.arange(len(kept)) / 3.0), 0.1)


def test_a_long_quiet_span_starts_a_new_grid_at_the_state():
    decimator = PublishDecimator(1.0, slack_s=0.05)
    assert decimator.due(10.0)
    assert decimator.due(11.0)
    assert decimator.due(15.3)  # after a quiet span of several periods
    assert not decimator.due(16.2)
    assert decimator.due(16.3)  # one period after the span's state, not on the old grid


def test_a_clock_that_goes_back_starts_again():
    decimator = PublishDecimator(1.0, slack_s=0.05)
    assert decimator.due(100.0)
    assert not decimator.due(100.5)
    assert decimator.due(50.0)  # a looping bag
    assert not decimator.due(50.5)
    assert decimator.due(51.0)


def test_restart_forgets_the_grid():
    decimator = PublishDecimator(1.0, slack_s=0.05)
    assert decimator.due(1.0)
    decimator.restart()
    assert decimator.due(1.2)


def test_a_state_a_hair_early_still_counts():
    decimator = PublishDecimator(0.2, slack_s=0.05)
    assert decimator.due(NOON_S)
    assert decimator.due(NOON_S + 0.2 - 2.4e-7)


@pytest.mark.parametrize('period_s, slack_s, message', [
    (0.0, 0.0, 'period_s must be positive'), (-1.0, 0.0, 'period_s must be positive'),
    (1.0, 1.0, 'slack_s must lie in'), (1.0, -0.1, 'slack_s must lie in'),
    (float('nan'), 0.0, 'period_s must be finite')])
def test_bad_settings_are_refused(period_s, slack_s, message):
    with pytest.raises(ValueError, match=message):
        PublishDecimator(period_s, slack_s)
