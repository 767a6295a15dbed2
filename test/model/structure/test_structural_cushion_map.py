"""The plant's cushion map from the structural model: read off the path, cached per design."""

from dataclasses import replace
import threading
import time

import numpy as np
import pytest

from flectofold_model.actuation import ActuationModel, DEMONSTRATOR_ACTUATED
from flectofold_model.actuation.cushion_map import CushionMap
from flectofold_model.structure import cushion_tables
from flectofold_model.structure.cushion_tables import (cache_key, structural_cushion_map,
                                                       structural_tables)
from flectofold_model.structure.panel import PanelMesh, structural_path

#: The quickest mesh. On it the demonstrator passes a spurious pressure maximum (too few hinge
#: rows, msg_docs/structure.md); with a 0.5 GPa hinge it closes with its pressure rising all
#: the way (measured: 31 equilibria, about 9 s).
MESH = PanelMesh(20, 2, 1, 2)
PANEL = replace(DEMONSTRATOR_ACTUATED,
                hinge=replace(DEMONSTRATOR_ACTUATED.hinge, youngs_modulus_pa=5e8))
SAMPLES = 17


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv(cushion_tables.CACHE_ENVIRONMENT, str(tmp_path / 'cache'))
    return tmp_path / 'cache'


@pytest.fixture(scope='module')
def path():
    return structural_path(PANEL, MESH)


@pytest.fixture
def traces(path, monkeypatch):
    """Count the paths traced; each gives the module's path (traced once, deterministic)."""
    calls = []

    def traced(actuated, mesh, **kwargs):
        assert (actuated, mesh) == (PANEL, MESH)
        calls.append(actuated)
        return path

    monkeypatch.setattr(cushion_tables, 'structural_path', traced)
    return calls


def test_the_tables_are_the_path_read_at_the_closures(cache, path, traces):
    pressure, volume, compliance, fold = structural_tables(PANEL, MESH, SAMPLES)
    model = ActuationModel([PANEL] * SAMPLES)
    closures = np.linspace(0.0, 1.0, SAMPLES)
    expected_fold = model.fold.state_from_closure(closures).apex_fold_angle_rad
    assert fold == pytest.approx(expected_fold, rel=1e-9)
    # At the path's own equilibria the tables hold its pressure and air.
    middle = SAMPLES // 2
    assert pressure[middle] == pytest.approx(
        np.interp(fold[middle], path.apex_fold_rad, path.pressure_pa), rel=1e-12)
    assert volume[middle] - volume[0] == pytest.approx(
        np.interp(fold[middle], path.apex_fold_rad, path.air_m3), rel=1e-9)
    assert pressure[0] == 0.0 and np.all(np.diff(pressure) > 0.0)
    assert np.all(np.diff(volume) > 0.0) and np.all(compliance > 0.0)
    # The compliance is dV/dp along the path: against the table's own differences.
    rate = np.diff(volume) / np.diff(pressure)
    assert compliance[middle] == pytest.approx(0.5 * (rate[middle - 1] + rate[middle]), rel=0.2)


def test_the_tables_are_computed_once_per_design_and_then_read_from_the_cache(
        cache, traces):
    first = structural_tables(PANEL, MESH, SAMPLES)
    assert len(traces) == 1
    assert len(list(cache.glob('*.npz'))) == 1
    assert not list(cache.glob('*.partial*'))
    again = structural_tables(PANEL, MESH, SAMPLES)
    assert len(traces) == 1
    for a, b in zip(first, again):
        assert np.array_equal(a, b)
    structural_tables(PANEL, MESH, SAMPLES, cache=False)
    assert len(traces) == 2
    # Another design, mesh or sample count is another key.
    other = replace(PANEL, hinge=replace(PANEL.hinge, youngs_modulus_pa=3e9))
    keys = {cache_key(PANEL, MESH, SAMPLES), cache_key(other, MESH, SAMPLES),
            cache_key(PANEL, PanelMesh(), SAMPLES), cache_key(PANEL, MESH, SAMPLES + 1)}
    assert len(keys) == 4


def test_a_damaged_cache_entry_is_computed_afresh(cache, traces):
    structural_tables(PANEL, MESH, SAMPLES)
    (entry,) = cache.glob('*.npz')
    entry.write_bytes(entry.read_bytes()[:100])
    tables = structural_tables(PANEL, MESH, SAMPLES)
    assert len(traces) == 2
    assert all(t.shape == (SAMPLES,) for t in tables)
    assert len(entry.read_bytes()) > 100


def test_the_map_drives_the_plant_tables_and_shares_one_path_per_design(cache, traces):
    panels = [PANEL] * 3
    cushion_map = structural_cushion_map(panels, MESH, SAMPLES)
    assert len(traces) == 1
    assert isinstance(cushion_map, CushionMap)
    assert cushion_map.distinct_count == 1 and cushion_map.pressure_pa.shape == (3, SAMPLES)
    pressure, volume, compliance, _ = structural_tables(PANEL, MESH, SAMPLES)
    half = float(np.interp(0.5, np.linspace(0.0, 1.0, SAMPLES), pressure))
    assert cushion_map.closure(np.full(3, half)) == pytest.approx(0.5, abs=1e-9)
    held, rate = cushion_map(np.full(3, half))
    assert held == pytest.approx(np.interp(0.5, np.linspace(0.0, 1.0, SAMPLES), volume))
    assert rate == pytest.approx(np.interp(0.5, np.linspace(0.0, 1.0, SAMPLES), compliance))


def test_a_panel_that_snaps_or_does_not_close_gets_no_map(cache, path, monkeypatch):
    # The demonstrator's own hinge passes a pressure maximum on this mesh.
    with pytest.raises(ValueError, match='passes a pressure maximum of .* a pressure '
                                         'regulator would snap the panel through'):
        structural_tables(DEMONSTRATOR_ACTUATED, MESH, SAMPLES)
    # A path that ended before the closed fold (the hexagon's, the 1000 mm variant's).
    ended = replace(path, ended='no equilibrium found beyond 19.2 L at 445 Pa')
    monkeypatch.setattr(cushion_tables, 'structural_path', lambda *args, **kwargs: ended)
    with pytest.raises(ValueError, match=r'does not close in the structure \(no equilibrium '
                                         r'found beyond 19.2 L at 445 Pa\): no structural'):
        structural_tables(PANEL, MESH, SAMPLES)
    # A path that closes but loses stability with the air held too (a bifurcation).
    flags = np.ones(len(path.pressure_pa), dtype=bool)
    flags[3:] = False
    crossed = replace(path, ended='closed', stable_at_pressure=flags, stable_at_volume=flags)
    monkeypatch.setattr(cushion_tables, 'structural_path', lambda *args, **kwargs: crossed)
    with pytest.raises(ValueError, match=r'not stable with the pressure held from .* on \(a '
                                         r'bifurcation\): no cushion map'):
        structural_tables(PANEL, MESH, SAMPLES)
    with pytest.raises(TypeError, match='quad panels'):
        structural_tables(object(), MESH, SAMPLES)
    for samples in (2, 3.0, True):
        with pytest.raises(ValueError, match='samples must be an integer of at least 3'):
            structural_tables(DEMONSTRATOR_ACTUATED, MESH, samples)


@pytest.mark.parametrize('change, message', [
    (lambda t: [t[0][:, ::-1], *t[1:]], 'not monotone'),
    (lambda t: [t[0], t[1], -t[2], t[3]], 'compliance be positive'),
    (lambda t: [t[0], t[1][:, ::-1], t[2], t[3]], 'volume must rise'),
    (lambda t: [t[0][:, :2], t[1][:, :2], t[2][:, :2], t[3][:, :2]], 'at least 3'),
    (lambda t: [t[0], t[1], t[2] * np.nan, t[3]], 'finite'),
    (lambda t: t[:3], 'four'),
])
def test_a_map_from_tables_refuses_tables_a_plant_cannot_use(change, message):
    closures = np.linspace(0.0, 1.0, 5)[None]
    good = [1e3 * closures, 1e-3 * (1 + closures), np.full((1, 5), 1e-6), closures]
    CushionMap.from_tables(good, [0, 0])
    with pytest.raises(ValueError, match=message):
        CushionMap.from_tables(change(good), [0])
    with pytest.raises(ValueError, match='row must index the 1 rows'):
        CushionMap.from_tables(good, [1])


def test_callers_that_ask_for_one_design_together_trace_it_once(cache, path, monkeypatch):
    started, calls = threading.Event(), []

    def slow(actuated, mesh, **kwargs):
        calls.append(actuated)
        started.set()
        time.sleep(0.5)  # the other caller arrives while this one traces
        return path

    monkeypatch.setattr(cushion_tables, 'structural_path', slow)
    results = []
    first = threading.Thread(target=lambda: results.append(
        structural_tables(PANEL, MESH, SAMPLES)))
    first.start()
    assert started.wait(timeout=60.0)
    second = threading.Thread(target=lambda: results.append(
        structural_tables(PANEL, MESH, SAMPLES)))
    second.start()
    first.join(timeout=120.0)
    second.join(timeout=120.0)
    assert len(results) == 2 and len(calls) == 1
    for a, b in zip(*results):
        assert np.array_equal(a, b)
