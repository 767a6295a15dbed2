"""The day report: a small facade through a summer day, its figures and its plot."""

import numpy as np
import pytest

from flectofold_model.environment import sun
from flectofold_model.facade.description import build_facade
from flectofold_model.kinematics.kinds import fold_model_of
from flectofold_model.scheduling import day_report
from flectofold_model.scheduling.day_report import plot, simulate_day
from flectofold_model.scheduling.facade_schedule import scheduler_parameters
from flectofold_model.scheduling.frontier import view_on_frontier

CONTROL = ('shading_target: 0.9, look_ahead_s: 1800, min_dwell_s: 1800, default_closure: 1.0, '
           'max_parallel_fills: 1')
STEP_S = 1800.0
SAMPLES = 12


@pytest.fixture(scope='module')
def target_facade(small_facade_text):
    return build_facade(small_facade_text('controller: target, ' + CONTROL))


@pytest.fixture(scope='module')
def summer(target_facade):
    """Run the day under the target rule (the tests of the rule's own figures use it)."""
    return simulate_day(target_facade, '2026-06-21', step_s=STEP_S, samples=SAMPLES)


@pytest.fixture(scope='module')
def predictive_summer(small_facade_text):
    """Run the same facade and day, its controller not named: the predictive one."""
    return simulate_day(build_facade(small_facade_text(CONTROL)), '2026-06-21', step_s=STEP_S,
                        samples=SAMPLES)


def test_schedule_trades_view_for_shading_between_the_baselines(summer):
    assert summer.always_open.blocked_direct_fraction > 0.95
    assert summer.always_open.view_fraction == pytest.approx(0.0, abs=0.02)
    assert summer.always_closed.view_fraction > 0.6
    scheduled = summer.scheduled
    assert scheduled.blocked_direct_fraction > summer.always_closed.blocked_direct_fraction
    assert scheduled.blocked_direct_fraction > 0.85  # target 0.9 on most sunlit steps
    assert scheduled.view_fraction > summer.always_open.view_fraction + 0.3


def test_schedule_respects_the_hardware_limits(summer, predictive_summer):
    for report in (summer, predictive_summer):
        for outcome in (report.scheduled, report.other):
            assert outcome.peak_fills <= 1
            assert outcome.air_nl >= 0
            assert outcome.actuations_per_panel <= 20
        for closure in (report.closure, report.other_closure):
            assert np.all((closure >= 0) & (closure <= 1))


def test_night_is_without_sun_and_panels_fold_for_view(summer):
    night = summer.elevation_deg < -5
    assert not summer.sunlit[night].any()
    np.testing.assert_allclose(summer.closure[night][-1], 1.0)


def test_plot_writes_a_png(summer, tmp_path):
    path = plot(summer, tmp_path / 'day.png')
    assert path.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


def test_plot_adds_the_frontier_panel_below_the_day(predictive_summer, tmp_path):
    data = plot(predictive_summer, tmp_path / 'day.png').read_bytes()
    width, height = (int.from_bytes(data[i:i + 4], 'big') for i in (16, 20))
    assert (width, height) == (900, 1200)  # 9 x 12 in at 100 dpi: four panels
    assert predictive_summer.frontier_limited


def test_the_predictive_controller_is_scheduled_unless_the_facade_names_the_target_rule(
        summer, predictive_summer):
    assert (predictive_summer.controller, predictive_summer.other_name) == \
        ('predictive', 'target rule')
    assert (summer.controller, summer.other_name) == ('target', 'predictive')
    # each controller's run is the same whichever row it takes
    assert predictive_summer.scheduled == summer.other
    assert predictive_summer.other == summer.scheduled
    np.testing.assert_array_equal(predictive_summer.closure, summer.other_closure)
    np.testing.assert_array_equal(predictive_summer.other_closure, summer.closure)
    assert not np.array_equal(summer.closure, predictive_summer.closure)


def test_the_target_controller_runs_the_shading_rule_through_the_gated_scheduler(
        target_facade, summer):
    """The rule as the day report ran it before the predictive controller: same closures."""
    epochs = sun.day_epochs('2026-06-21', target_facade.utc_offset_h, STEP_S)
    position = sun.solar_position(epochs, target_facade.site)
    sun_panel = target_facade.sun_in_panel_frames(position.enu)
    sunlit = (sun_panel[..., 2] > 0) & position.above_horizon[:, None]
    fold = fold_model_of(target_facade.panels)
    blocked = day_report._blocked_table(fold, sun_panel, sunlit, SAMPLES)
    view = day_report._view_table(fold, SAMPLES)
    desired = day_report._desired(blocked, view, sunlit, 0.9, 1)
    closure, _, air = day_report._schedule(target_facade, scheduler_parameters(target_facade),
                                           epochs, desired, summer.dni_w_m2)
    np.testing.assert_array_equal(summer.closure, closure)
    assert summer.scheduled.air_nl == pytest.approx(float(np.sum(air)))


def test_the_limit_bounds_every_row_at_its_own_blocking(summer, predictive_summer):
    for report in (summer, predictive_summer):
        names = [name for name, _ in report.rows()]
        assert names == ['scheduled', report.other_name, 'always open', 'always closed',
                         'limit']
        assert set(report.gaps) == set(names) - {'limit'}
        for name in report.gaps:
            blocked, view = report.on_limit_axes[name]
            assert report.gaps[name] >= -1e-9, name
            # the straight lines between the supported points bound it too
            line = view_on_frontier(report.frontier_limited,
                                    blocked * report.incident_direct_kwh_m2)
            assert float(line) / report.daylight_h >= view - 1e-9, name
        limit, scheduled = report.limit_outcome, report.on_limit_axes['scheduled']
        assert limit.view_fraction >= scheduled[1] - 1e-12
        assert limit.blocked_direct_fraction >= scheduled[0] - 1e-12
        assert report.gaps['scheduled'] == pytest.approx(limit.view_fraction - scheduled[1])
        # the bracket: a schedule within the limits keeps the lower end
        assert 0.0 <= report.limit.width_h < report.limit.view_weighted_upper_h
    assert summer.gaps['always closed'] == pytest.approx(0.0, abs=1e-9)  # the most view


def test_the_limit_weighs_blocking_and_view_as_the_rows_do(summer, predictive_summer):
    """The limit's conversion gives each row's own fractions.

    The four panels of the small saddle are alike, so footprint shares weigh as equal panels
    and their mean view is each panel's (on the demonstrator they differ by under 1e-3).
    """
    for report in (summer, predictive_summer):
        for name, outcome in report.rows():
            blocked, view = report.on_limit_axes[name]
            assert blocked == pytest.approx(outcome.blocked_direct_fraction, abs=1e-9), name
            assert view == pytest.approx(outcome.view_fraction, abs=1e-9), name


def test_lines_hold_every_row_with_its_gap_and_the_limit(predictive_summer):
    lines = predictive_summer.lines()
    assert 'predictive controller' in lines[0]
    assert 'gap view' in lines[1]
    rows = {line[:15].strip(): line[15:].split() for line in lines[2:7]}
    assert list(rows) == ['scheduled', 'target rule', 'always open', 'always closed', 'limit']
    assert rows['limit'][4:] == ['-', '-', '-']  # peak fills relaxed, no gap to itself
    assert float(rows['limit'][1]) == pytest.approx(
        predictive_summer.limit_outcome.view_fraction, abs=5e-4)
    assert float(rows['scheduled'][5]) == pytest.approx(
        predictive_summer.gaps['scheduled'], abs=5e-4)
    assert any(line.startswith('limit: with the whole day known') for line in lines)
