"""The closure the facade's schedule commands at one instant of a clear day."""

from datetime import datetime

import numpy as np
import pytest

from flectofold_model.facade import load_facade
from flectofold_model.scheduling.facade_schedule import representative_panel
from flectofold_model.scheduling.scheduled_closure import decision_times, scheduled_closure
from flectofold_model.shading.table import ShadingTable


@pytest.fixture(scope='module')
def demonstrator():
    facade = load_facade('demonstrator_6x6')
    return facade, ShadingTable(representative_panel(facade))


def epoch(text):
    return datetime.fromisoformat(text).timestamp()


def test_decisions_run_from_local_midnight_every_period(demonstrator):
    facade, _ = demonstrator  # period 60 s, clock UTC+2
    times = decision_times(facade, epoch('2026-06-21T00:10:30+02:00'))
    assert times[0] == epoch('2026-06-21T00:00:00+02:00')
    assert len(times) == 11 and np.all(np.diff(times) == 60.0)
    assert decision_times(facade, epoch('2026-06-20T23:59:59+02:00'))[0] == epoch(
        '2026-06-20T00:00:00+02:00')


def test_night_holds_the_default_closure_and_noon_shades(demonstrator):
    facade, table = demonstrator
    night = scheduled_closure(facade, epoch('2026-06-21T03:00:00+02:00'), table)
    np.testing.assert_array_equal(night, facade.control['default_closure'])
    noon = scheduled_closure(facade, epoch('2026-06-21T13:00:00+02:00'), table)
    assert noon.shape == (len(facade),) and np.all((noon >= 0) & (noon <= 1))
    assert noon.min() < 1.0  # the high summer sun on a south facade: some panels shade


def test_the_last_decision_holds_until_the_next(demonstrator):
    facade, table = demonstrator
    at = scheduled_closure(facade, epoch('2026-06-21T10:00:00+02:00'), table)
    later = scheduled_closure(facade, epoch('2026-06-21T10:00:59+02:00'), table)
    np.testing.assert_array_equal(at, later)


@pytest.mark.parametrize('bad', [float('nan'), float('inf')])
def test_a_time_the_schedule_cannot_give_is_refused(demonstrator, bad):
    facade, table = demonstrator
    with pytest.raises(ValueError):
        scheduled_closure(facade, bad, table)


def test_beyond_the_solar_position_years_is_refused(demonstrator):
    facade, table = demonstrator
    with pytest.raises(ValueError):
        scheduled_closure(facade, epoch('6500-01-01T00:00:00+00:00'), table)
