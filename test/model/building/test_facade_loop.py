"""The facade in a building simulation's loop, against the project's own ray casting."""

import numpy as np
import pytest

from flectofold_model.building.facade_loop import FacadeInTheLoop, STRATEGIES
from flectofold_model.building.facade_optics import (beam_transmittance, cosine_directions,
                                                     diffuse_transmittance,
                                                     effective_transmittance)
from flectofold_model.environment import Site
from flectofold_model.facade.description import build_facade
from flectofold_model.kinematics.kinds import fold_model_of
from flectofold_model.scheduling.day_report import CANDIDATE_CLOSURES
from flectofold_model.scheduling.facade_schedule import representative_panel
from flectofold_model.shading.ray_casting import blocked_fraction
from flectofold_model.shading.table import ShadingTable

STATION = Site(33.45, -111.98, 337.0)  # Phoenix
#: 2001-03-21 06:00 local standard time (UTC-7)
MORNING_S = 985179600.0 - 1 * 3600.0


@pytest.fixture(scope='module')
def facade(small_facade_text):
    return build_facade(small_facade_text('default_closure: 1.0'))


@pytest.fixture(scope='module')
def table(facade):
    return ShadingTable(representative_panel(facade), closures=CANDIDATE_CLOSURES)


def test_the_beam_transmittance_is_the_ray_cast_share_of_sun_that_passes(facade, table):
    loop = FacadeInTheLoop(facade, 'threshold', STATION, MORNING_S, table=table)
    fold = fold_model_of(loop.facade.panels)
    rng = np.random.default_rng(2)
    for _ in range(4):
        closure = rng.uniform(0.0, 1.0, len(facade))
        sun = np.array([rng.uniform(-0.5, 0.5), -0.7, 0.5])
        sun /= np.linalg.norm(sun)
        in_panels = loop.facade.sun_in_panel_frames(sun)
        shape = np.array([fold.state_from_closure(c).shape_parameter[i]
                          for i, c in enumerate(closure)])
        cast = blocked_fraction(fold.batch, shape, in_panels).blocked_fraction
        expected = float((1.0 - cast) @ loop.weights)
        got = beam_transmittance(loop.facade, table, closure, sun, loop.weights)
        # the table interpolates between 5-degree sun directions and 0.1 closures
        assert got == pytest.approx(expected, abs=0.03)


def test_the_diffuse_transmittance_averages_the_ray_cast_hemisphere(facade, table):
    diffuse = diffuse_transmittance(table)
    assert np.all(np.diff(diffuse) > 0)  # folding lets more sky through
    fold = fold_model_of([representative_panel(facade)])
    directions = cosine_directions(256)
    for index in (0, 5, 10):
        shape = fold.state_from_closure(CANDIDATE_CLOSURES[index]).shape_parameter[0]
        cast = blocked_fraction(fold.batch.take(np.zeros(256, np.intp)), shape,
                                directions).blocked_fraction
        assert diffuse[index] == pytest.approx(1.0 - cast.mean(), abs=0.02)


def test_the_mixed_transmittance_passes_the_right_energy():
    assert effective_transmittance(0.5, 0.2, 300.0, 100.0) == pytest.approx(
        (0.5 * 300 + 0.2 * 100) / 400)
    assert effective_transmittance(0.5, 0.2, 0.0, 0.0) == 0.2


@pytest.mark.parametrize('strategy', STRATEGIES)
def test_every_strategy_steps_through_a_day_within_the_scheduler(facade, table, strategy):
    loop = FacadeInTheLoop(facade, strategy, STATION, MORNING_S, table=table)
    results = [loop.step(MORNING_S + 600.0 * i, 600.0, 800.0, 100.0, 3.0)
               for i in range(72)]
    closures = np.array([r.closure for r in results])
    assert np.all((closures >= 0) & (closures <= 1))
    taus = np.array([r.transmittance for r in results])
    assert np.all((taus >= 0) & (taus <= 1))
    if strategy in ('always open', 'always closed'):
        assert loop.moves.sum() == 0 and np.ptp(closures) == 0
    assert loop.moves.max() <= 20  # the daily cap


def test_a_storm_vents_the_scheduled_facade(facade, table):
    loop = FacadeInTheLoop(facade, 'scheduled', STATION, MORNING_S, table=table)
    for i in range(12):
        loop.step(MORNING_S + 600.0 * i, 600.0, 0.0, 50.0, 3.0)
    assert np.all(loop.closure == 1.0)  # no sun worth shading: folded for the view
    result = loop.step(MORNING_S + 7200.0, 600.0, 0.0, 50.0, 25.0)
    assert np.all(result.closure == 0.0)  # tripped 5 s into the step, vented flat


def test_an_unknown_strategy_is_refused(facade, table):
    with pytest.raises(ValueError, match='strategy must be one of'):
        FacadeInTheLoop(facade, 'sometimes', STATION, MORNING_S, table=table)


def test_the_room_aware_objective_prices_solar_gain_by_the_rooms_need():
    from flectofold_model.scheduling.objective import RoomAware, Stage
    stage = Stage(direct_w_m2=np.array([[500.0]]), blocked=np.array([[[1.0, 0.0]]]),
                  view=np.array([0.0, 0.8]), daylight=np.array([True]), step_h=np.ones(1))
    objective = RoomAware(90.0, np.array([0.0, 0.5]))
    objective.observe(1000.0, 0.0, 100.0)  # cooling: keep the sun out
    cooling = objective.rewards(stage)[0, 0]
    assert cooling[0] == 500.0 and cooling[1] == pytest.approx(-50.0 + 72.0)
    objective.observe(0.0, 1000.0, 100.0)  # heating: the sun is welcome
    heating = objective.rewards(stage)[0, 0]
    assert heating[0] == -250.0 and heating[1] == pytest.approx(25.0 + 72.0)
    with pytest.raises(ValueError, match='heating_value'):
        RoomAware(90.0, np.zeros(2), heating_value=1.5)


def test_the_room_aware_objective_adds_daylight_and_glare_by_day_only_when_told():
    from flectofold_model.scheduling.objective import RoomAware, Stage
    stage = Stage(direct_w_m2=np.zeros((2, 1)), blocked=np.zeros((2, 1, 2)),
                  view=np.zeros(2), daylight=np.array([True, False]), step_h=np.ones(2))
    objective = RoomAware(90.0, np.zeros(2), daylight_value_w_m2=60.0, glare_value_w_m2=300.0)
    objective.observe(0.0, 0.0, 0.0)  # nothing known of the room's light: no term
    assert np.all(objective.rewards(stage) == 0.0)
    objective.observe(0.0, 0.0, 0.0, daylit=[0.5, 1.0], glare=[0.0, 1.0])
    rewards = objective.rewards(stage)
    np.testing.assert_allclose(rewards[0, 0], [30.0, 60.0 - 300.0])
    np.testing.assert_allclose(rewards[1, 0], [0.0, 0.0])  # the sun is down
    for bad in ([0.5], [0.5, np.nan]):
        with pytest.raises(ValueError, match='one per candidate'):
            objective.observe(0.0, 0.0, 0.0, daylit=bad, glare=[0.0, 0.0])
    for name in ('daylight_value_w_m2', 'glare_value_w_m2'):
        assert RoomAware(90.0, np.zeros(2), **{name: 0.0})  # the bound itself
        with pytest.raises(ValueError, match=name):
            RoomAware(90.0, np.zeros(2), **{name: -1e-9})
