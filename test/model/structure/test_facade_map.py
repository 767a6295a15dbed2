"""A facade's cushion map as its description chooses: energy statics or the structure."""

from dataclasses import replace

import numpy as np
import pytest

from flectofold_model.actuation import (actuated_like, actuation_model_of,
                                        ATMOSPHERIC_PRESSURE_PA, DEMONSTRATOR_PLANT)
from flectofold_model.actuation.cushion_map import CushionMap, distinct_panels
from flectofold_model.control import facade_loops
from flectofold_model.facade import build_facade, facade_path, FacadeError, load_facade
from flectofold_model.facade.description import DEFAULT_FACADE
from flectofold_model.facade.footprint import representative_index
from flectofold_model.scheduling.facade_schedule import full_close_air_nl
from flectofold_model.structure import cushion_tables
from flectofold_model.structure.cushion_tables import NotCached
from flectofold_model.structure.facade_map import facade_cushion_map
from flectofold_model.structure.panel import PanelMesh, structural_path

#: The quickest mesh; with a 0.5 GPa hinge the panel closes with its pressure rising all the
#: way on it (test_structural_cushion_map.py).
MESH = PanelMesh(20, 2, 1, 2)
TEXT = DEFAULT_FACADE.read_text()


def with_actuation(cushion_map):
    return build_facade(TEXT + f'\nactuation:\n  cushion_map: {cushion_map}\n')


@pytest.fixture(scope='module')
def facade():
    return with_actuation('structural')


@pytest.fixture(scope='module')
def median_path(facade):
    """Trace the median panel's path quickly: the tiny mesh and a soft hinge (about 10 s)."""
    median = actuated_like(facade.panels[representative_index(facade)])
    return structural_path(replace(median, hinge=replace(median.hinge, youngs_modulus_pa=5e8)),
                           MESH)


@pytest.fixture
def traces(median_path, monkeypatch, tmp_path):
    """Empty the cache; count every path traced, each the median panel's quick one."""
    monkeypatch.setenv(cushion_tables.CACHE_ENVIRONMENT, str(tmp_path / 'cache'))
    calls = []

    def traced(actuated, mesh, **kwargs):
        calls.append(actuated)
        return median_path

    monkeypatch.setattr(cushion_tables, 'structural_path', traced)
    return calls


def test_a_description_keeps_the_energy_statics_unless_it_says_structural(facade):
    assert load_facade(DEFAULT_FACADE).cushion_map == 'energy'
    assert with_actuation('energy').cushion_map == 'energy'
    assert facade.cushion_map == 'structural'


@pytest.mark.parametrize('value, message', [
    ('fea', 'actuation.cushion_map: must be one of energy, structural'),
    ('1.0', 'actuation.cushion_map: must be a'),
    ('{a: 1}', 'actuation.cushion_map: must be a'),
])
def test_a_cushion_map_that_is_not_one_of_the_two_is_refused(value, message):
    with pytest.raises(FacadeError, match=message):
        with_actuation(value)


def test_an_unknown_actuation_key_is_refused():
    with pytest.raises(FacadeError, match='actuation.mesh: unknown key'):
        build_facade(TEXT + '\nactuation:\n  mesh: fine\n')


@pytest.mark.parametrize('choice', ['structural', 'structural_per_panel'])
def test_a_hexagon_facade_cannot_take_the_structural_map(choice):
    text = facade_path('hexagon_6x6').read_text()
    with pytest.raises(FacadeError, match=f'{choice} needs quad panels; the hexagonal module '
                                          f'does not close'):
        build_facade(text + f'\nactuation:\n  cushion_map: {choice}\n')


def test_the_energy_choice_is_each_panels_own_statics():
    facade = load_facade(DEFAULT_FACADE)
    model = actuation_model_of(actuated_like(panel) for panel in facade.panels[:3])
    ours, theirs = facade_cushion_map(facade, model).tables(), CushionMap(model).tables()
    for mine, other in zip(ours, theirs):
        assert np.array_equal(mine, other)


def test_without_a_cached_map_a_process_that_may_not_trace_is_told_the_command(
        facade, traces):
    model = actuation_model_of(actuated_like(panel) for panel in facade.panels[:2])
    median = facade.panel_ids[representative_index(facade)]
    with pytest.raises(NotCached, match=f'median panel {median}: no structural cushion map of '
                                        f'this panel design is cached .*structure_cache '
                                        f'--facade FILE'):
        facade_cushion_map(facade, model, trace=False)
    with pytest.raises(NotCached, match='structure_cache'):
        full_close_air_nl(facade)
    assert traces == []


def test_every_panel_takes_the_median_panels_structural_map_traced_once(facade, traces):
    model = actuation_model_of(actuated_like(panel) for panel in facade.panels)
    traced = facade_cushion_map(facade, model)
    assert len(traces) == 1 and traces[0] == actuated_like(
        facade.panels[representative_index(facade)])
    assert traced.distinct_count == 1 and traced.pressure_pa.shape[0] == len(facade)
    cached = facade_cushion_map(facade, model, trace=False)  # read back, nothing traced
    assert len(traces) == 1
    for mine, other in zip(traced.tables(), cached.tables()):
        assert np.array_equal(mine, other)
    energy = CushionMap(model)
    assert not np.allclose(traced.pressure_pa[:, -1], energy.pressure_pa[:, -1], rtol=0.05)


def test_the_scheduler_prices_a_full_close_with_the_structural_map(facade, traces):
    model = actuation_model_of(actuated_like(panel) for panel in facade.panels)
    pressure, volume, _, _ = (table[0] for table in facade_cushion_map(facade, model).tables())
    atmosphere, dead = ATMOSPHERIC_PRESSURE_PA, DEMONSTRATOR_PLANT.dead_volume_m3
    expected_nl = ((atmosphere + pressure[-1]) * (volume[-1] + dead) -
                   atmosphere * (volume[0] + dead)) / atmosphere * 1e3
    air_nl = full_close_air_nl(facade)
    assert air_nl.shape == (len(facade),) and air_nl == pytest.approx(expected_nl, rel=1e-12)
    energy_nl = full_close_air_nl(load_facade(DEFAULT_FACADE))
    assert not np.allclose(air_nl, energy_nl, rtol=0.05)


def test_the_loops_and_their_plant_run_on_the_structural_map(facade, traces):
    ids = facade.panel_ids[:2]
    facade_cushion_map(facade, actuation_model_of(
        actuated_like(panel) for panel in facade.panels[:2]))  # cached now
    loops = facade_loops(facade, ids, trace=False)
    pressure = loops.map.tables()[0][0]
    assert loops.map.distinct_count == 1
    assert loops.map.pressure_for_closure(np.ones(2)) == pytest.approx(pressure[-1])
    assert len(traces) == 1


@pytest.fixture(scope='module')
def each_facade():
    return with_actuation('structural_per_panel')


def test_per_panel_every_design_is_traced_once_and_drives_its_own_panels(each_facade, traces):
    panels = [actuated_like(panel) for panel in each_facade.panels]
    model = actuation_model_of(panels)
    traced = facade_cushion_map(each_facade, model)
    distinct, row = distinct_panels(panels)
    assert len(distinct) == len(each_facade) == 36  # the saddle: every panel its own design
    assert traced.distinct_count == len(distinct) and traces == distinct
    pressure, volume, compliance, rows = traced.tables()
    for index, panel in enumerate(panels):
        own = cushion_tables.structural_tables(panel, trace=False)  # its own cache entry
        for mine, other in zip((pressure, volume, compliance), own[:3]):
            assert np.array_equal(mine[rows[index]], other)
    assert np.ptp(pressure[:, -1]) > 0.0  # the panels' closed pressures differ
    # A process of two panels reads their maps back and traces nothing.
    two = facade_cushion_map(each_facade, actuation_model_of(panels[3:5]), trace=False)
    assert len(traces) == len(distinct) and two.distinct_count == 2
    assert np.array_equal(two.tables()[0], pressure[rows[3:5]])


def test_per_panel_the_scheduler_prices_each_panels_full_close_with_its_own_map(
        each_facade, traces):
    panels = [actuated_like(panel) for panel in each_facade.panels]
    pressure, volume, _, rows = facade_cushion_map(each_facade,
                                                   actuation_model_of(panels)).tables()
    pressure, volume = pressure[rows], volume[rows]
    atmosphere, dead = ATMOSPHERIC_PRESSURE_PA, DEMONSTRATOR_PLANT.dead_volume_m3
    expected_nl = ((atmosphere + pressure[:, -1]) * (volume[:, -1] + dead) -
                   atmosphere * (volume[:, 0] + dead)) / atmosphere * 1e3
    air_nl = full_close_air_nl(each_facade)
    assert air_nl.shape == (len(each_facade),)
    assert air_nl == pytest.approx(expected_nl, rel=1e-12)
    assert np.ptp(air_nl) > 0.0


def test_per_panel_without_the_cached_maps_a_process_is_told_the_command(each_facade, traces):
    model = actuation_model_of(actuated_like(panel) for panel in each_facade.panels[:2])
    with pytest.raises(NotCached, match='structural_per_panel.*no structural cushion map of '
                                        'this panel design is cached .*structure_cache '
                                        '--facade FILE'):
        facade_cushion_map(each_facade, model, trace=False)
    with pytest.raises(NotCached, match='structure_cache'):
        full_close_air_nl(each_facade)
    assert traces == []
