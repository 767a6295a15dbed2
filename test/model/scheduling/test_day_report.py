"""The day report: a small facade through a summer day, its figures and its plot."""

import numpy as np
import pytest

from flectofold_model.facade.description import build_facade
from flectofold_model.scheduling.day_report import plot, simulate_day


@pytest.fixture(scope='module')
def summer(small_facade_text):
    text = small_facade_text('shading_target: 0.9, look_ahead_s: 1800, min_dwell_s: 1800, '
                             'default_closure: 1.0, max_parallel_fills: 1')
    return simulate_day(build_facade(text), '2026-06-21', step_s=1800.0, samples=12)


def test_schedule_trades_view_for_shading_between_the_baselines(summer):
    assert summer.always_open.blocked_direct_fraction > 0.95
    assert summer.always_open.view_fraction == pytest.approx(0.0, abs=0.02)
    assert summer.always_closed.view_fraction > 0.6
    scheduled = summer.scheduled
    assert scheduled.blocked_direct_fraction > summer.always_closed.blocked_direct_fraction
    assert scheduled.blocked_direct_fraction > 0.85  # target 0.9 on most sunlit steps
    assert scheduled.view_fraction > summer.always_open.view_fraction + 0.3


def test_schedule_respects_the_hardware_limits(summer):
    assert summer.scheduled.peak_fills <= 1
    assert summer.scheduled.air_nl >= 0
    assert summer.scheduled.actuations_per_panel <= 20
    assert np.all((summer.closure >= 0) & (summer.closure <= 1))


def test_night_is_without_sun_and_panels_fold_for_view(summer):
    night = summer.elevation_deg < -5
    assert not summer.sunlit[night].any()
    np.testing.assert_allclose(summer.closure[night][-1], 1.0)


def test_plot_writes_a_png(summer, tmp_path):
    path = plot(summer, tmp_path / 'day.png')
    assert path.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
