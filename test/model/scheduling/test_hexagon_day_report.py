"""The day report of a facade of hexagonal panels: finite figures, cast on the hexagons."""

import dataclasses

import numpy as np
import pytest

from flectofold_model.environment import sun
from flectofold_model.facade.description import build_facade
from flectofold_model.kinematics.hexagon_panel import HexagonPanel
from flectofold_model.kinematics.kinds import fold_model_of
from flectofold_model.scheduling.day_report import simulate_day
from flectofold_model.shading.ray_casting import blocked_fraction

SAMPLES = 12
STEP_S = 1800.0
HEXAGON_FACADE = """
name: small-hexagon
site: {latitude_deg: 48.78, longitude_deg: 9.18, elevation_m: 245, utc_offset_h: 2}
facade: {azimuth_deg: 180}
surface: {type: saddle, width_m: 3.0, height_m: 2.6, curvature_u_per_m: -0.08,
          curvature_v_per_m: 0.08}
grid: {gap_m: 0.1}
panel: {type: hexagon, circumradius_m: 0.62, fold_line_sag_m: 0.06, hinge_width_m: 0.03}
control: {shading_target: 0.9, look_ahead_s: 1800, min_dwell_s: 1800, default_closure: 1.0,
          max_parallel_fills: 1}
"""


@pytest.fixture(scope='module')
def facade():
    """Build a small saddle facade of four hexagonal modules (the facade's own lattice)."""
    facade = build_facade(HEXAGON_FACADE)
    assert len(facade) == 4 and all(isinstance(p, HexagonPanel) for p in facade.panels)
    return facade


@pytest.fixture(scope='module')
def summer(facade):
    return simulate_day(facade, '2026-06-21', step_s=STEP_S, samples=SAMPLES)


def test_figures_are_finite_and_the_schedule_lies_between_the_baselines(summer):
    outcomes = (summer.scheduled, summer.always_open, summer.always_closed)
    for outcome in outcomes:
        figures = dataclasses.astuple(outcome)
        assert all(np.isfinite(figures)), outcome
    assert summer.always_open.blocked_direct_fraction > 0.95
    assert summer.always_open.view_fraction == pytest.approx(0.0, abs=0.02)
    assert summer.always_closed.view_fraction > 0.3
    scheduled = summer.scheduled
    assert scheduled.blocked_direct_fraction > summer.always_closed.blocked_direct_fraction
    assert scheduled.blocked_direct_fraction > 0.85
    assert scheduled.view_fraction > summer.always_open.view_fraction + 0.2
    assert scheduled.peak_fills <= 1 and scheduled.air_nl > 0
    assert np.all((summer.closure >= 0) & (summer.closure <= 1))
    assert np.all(np.isfinite(summer.blocked)) and summer.sunlit.any()


def test_baselines_are_cast_against_the_hexagonal_meshes(facade, summer):
    """The always-closed figures are those of the hexagon's own mesh, cast directly."""
    epochs = sun.day_epochs('2026-06-21', facade.utc_offset_h, STEP_S)
    position = sun.solar_position(epochs, facade.site)
    sun_panel = facade.sun_in_panel_frames(position.enu)
    times, panels = np.nonzero(summer.sunlit)
    assert times.size > 0
    model = fold_model_of(facade.panels)
    for closure, report in ((1.0, summer.blocked_closed), (0.0, summer.blocked_open)):
        rise = model.state_from_closure(closure).shape_parameter
        direct = blocked_fraction(model.batch.take(panels), rise[panels],
                                  sun_panel[times, panels], samples=SAMPLES).blocked_fraction
        np.testing.assert_array_equal(report[times, panels], direct)
