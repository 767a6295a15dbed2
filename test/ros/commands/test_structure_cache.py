"""``structure_cache``, and processes of a facade that takes its cushion map from the structure.

Panel processes only read the cache (they must start in seconds; a path is about 15 s of
CPU): without the entry they refuse, naming the command; with it they start. ``structure_cache``
fills it, or finds it there.
"""

import os
import subprocess
import sys

import pytest
from ros_graph import domain_for, Graph
from structure_seed import quick_median_path, seed_structural_map

from flectofold_model.facade import build_facade
from flectofold_model.structure.cushion_tables import CACHE_ENVIRONMENT
from flectofold_ros.runtime.executables import EXECUTABLES

pytestmark = pytest.mark.graph


@pytest.fixture(scope='module')
def structural_facade_file(small_facade_text, tmp_path_factory):
    path = tmp_path_factory.mktemp('structural') / 'structural_small.yaml'
    path.write_text(small_facade_text('period_s: 60.0') +
                    'actuation: {cushion_map: structural}\n')
    return path


@pytest.fixture(scope='module')
def seeded_cache(structural_facade_file, tmp_path_factory):
    cache = tmp_path_factory.mktemp('seeded') / 'cache'
    facade = build_facade(structural_facade_file.read_text())
    path = quick_median_path(facade)
    return cache, seed_structural_map(facade, cache, path), path


def structure_cache(facade_file, cache):
    return subprocess.run([sys.executable, '-m', 'flectofold_ros', 'structure_cache',
                           '--facade', str(facade_file)], capture_output=True, text=True,
                          env=dict(os.environ, **{CACHE_ENVIRONMENT: str(cache)}), timeout=120)


def test_structure_cache_is_an_executable_of_the_package():
    assert EXECUTABLES['structure_cache'] == ('flectofold_ros.commands.structure_cache', 130)


def test_a_facade_on_the_energy_statics_has_nothing_to_compute(small_facade_text, tmp_path):
    energy = tmp_path / 'energy.yaml'
    energy.write_text(small_facade_text('period_s: 60.0'))
    result = structure_cache(energy, tmp_path / 'cache')
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == ('structure_cache: facade small takes its cushion map from '
                                     'the energy statics (actuation.cushion_map: energy): '
                                     'nothing to compute')
    assert not (tmp_path / 'cache').exists()


def test_a_facade_that_cannot_be_loaded_is_refused_with_exit_code_2(tmp_path):
    bad = tmp_path / 'bad.yaml'
    bad.write_text('name: bad\nactuation: {cushion_map: fea}\n')
    result = structure_cache(bad, tmp_path / 'cache')
    assert result.returncode == 2 and 'Traceback' not in result.stderr, result.stderr
    assert result.stderr.startswith('structure_cache: ')


def test_a_cached_map_is_found_and_described(structural_facade_file, seeded_cache):
    cache, cushion_map, _ = seeded_cache
    result = structure_cache(structural_facade_file, cache)
    assert result.returncode == 0, result.stderr
    pressure, volume = (table[0] for table in cushion_map.tables()[:2])
    assert result.stdout.strip() == (
        f'structure_cache: structural cushion map of small (median panel r01c00), cached: '
        f'closed at {pressure[-1] / 1e3:.2f} kPa, cushion {volume[0] * 1e3:.2f} L open, '
        f'{volume[-1] * 1e3:.2f} L closed')


def test_a_panel_process_without_the_cached_map_refuses_naming_the_command(
        structural_facade_file, tmp_path):
    graph = Graph(domain_for(57))
    graph.env[CACHE_ENVIRONMENT] = str(tmp_path / 'empty')
    try:
        process = graph.start('panel_group', '--panels', 'r00c00,r00c01', '--facade',
                              str(structural_facade_file))
        code, output = process.wait(timeout=60.0), process.stdout.read()
    finally:
        graph.close()
    assert code == 2 and 'Traceback' not in output, output
    lines = output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('panel_group: facade small takes its '
                                                   'cushion map from the structure'), output
    assert 'median panel r01c00: no structural cushion map of this panel design is cached' in \
        lines[0] and 'compute it once with `structure_cache --facade FILE`' in lines[0], output


def test_a_panel_process_with_the_cached_map_starts(structural_facade_file, seeded_cache):
    graph = Graph(domain_for(57))
    graph.env[CACHE_ENVIRONMENT] = str(seeded_cache[0])
    try:
        process = graph.start('panel_group', '--panels', 'r00c00,r00c01', '--facade',
                              str(structural_facade_file))
        lines = graph.read_until(process, lambda line: 'panel(s) ready' in line, 60.0)
        assert lines and '2 panel(s) ready: r00c00, r00c01' in lines[-1], lines
    finally:
        graph.close()


def test_an_uncached_map_is_traced_once_with_progress_and_then_found(
        structural_facade_file, seeded_cache, tmp_path, monkeypatch, capsys):
    from flectofold_model.structure import cushion_tables
    from flectofold_ros.commands.structure_cache import prepare_structural_map
    facade = build_facade(structural_facade_file.read_text())
    monkeypatch.setenv(CACHE_ENVIRONMENT, str(tmp_path / 'cache'))
    calls = []

    def traced(actuated, mesh, progress=None):  # the seeded tables, through the real path
        calls.append(actuated)
        for pressure_pa, fold_rad in ((1000.0, 0.5), (2000.0, 1.0)):
            progress(pressure_pa, fold_rad)
        return seeded_cache[2]

    monkeypatch.setattr(cushion_tables, 'structural_path', traced)
    first = prepare_structural_map(facade, 'x')
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == (f'x: tracing the structural path of the median panel r01c00 of small '
                        f'(about 15 s of CPU, once; cached in {tmp_path / "cache"})')
    assert lines[-1].startswith('x: structural cushion map of small (median panel r01c00), '
                                'traced in ') and ' s of CPU: closed at ' in lines[-1]
    again = prepare_structural_map(facade, 'x')
    assert len(calls) == 1 and 'r01c00), cached: closed at ' in capsys.readouterr().out
    assert (first.tables()[0] == again.tables()[0]).all()


def test_per_panel_every_design_is_traced_once_with_a_line_each_and_then_found(
        small_facade_text, seeded_cache, tmp_path, monkeypatch, capsys):
    from dataclasses import replace
    from flectofold_model.actuation import actuated_like
    from flectofold_model.actuation.cushion_map import distinct_panels
    from flectofold_model.structure import cushion_tables
    from flectofold_ros.commands.structure_cache import prepare_structural_map
    facade = build_facade(small_facade_text('period_s: 60.0') +
                          'actuation: {cushion_map: structural_per_panel}\n')
    designs = len(distinct_panels([actuated_like(panel) for panel in facade.panels])[0])
    monkeypatch.setenv(CACHE_ENVIRONMENT, str(tmp_path / 'cache'))
    calls = []

    def traced(actuated, mesh, progress=None):
        calls.append(actuated)
        return seeded_cache[2]

    monkeypatch.setattr(cushion_tables, 'structural_path', traced)
    first = prepare_structural_map(facade, 'x')
    lines = capsys.readouterr().out.splitlines()
    assert len(calls) == designs and len(lines) == designs + 2, lines
    assert lines[0] == (f'x: tracing the structural paths of {designs} of the {designs} panel '
                        f'designs of small (about 15 s of CPU each, once; cached in '
                        f'{tmp_path / "cache"})')
    assert all(line.startswith(f'x: {count}/{designs} panel r') and ': closed at ' in line
               for count, line in enumerate(lines[1:-1], 1)), lines
    assert lines[-1].startswith(f'x: structural cushion maps of the 4 panels of small '
                                f'({designs} designs), traced {designs} in '), lines
    again = prepare_structural_map(facade, 'x')
    assert len(calls) == designs
    assert capsys.readouterr().out.startswith(f'x: structural cushion maps of the 4 panels of '
                                              f'small ({designs} designs), cached: closed at ')
    assert (first.tables()[0] == again.tables()[0]).all()
    # A design that does not close is named by its first panel.
    monkeypatch.setenv(CACHE_ENVIRONMENT, str(tmp_path / 'other'))
    monkeypatch.setattr(cushion_tables, 'structural_path',
                        lambda *_, **__: replace(seeded_cache[2], ended='not closed'))
    with pytest.raises(ValueError, match=r'panel r\d\dc\d\d of small: the panel does not '
                                         r'close in the structure \(not closed\)'):
        prepare_structural_map(facade, 'x')


def test_a_bringup_day_runs_on_the_cached_structural_map(structural_facade_file, seeded_cache):
    cache, cushion_map, _ = seeded_cache
    graph = Graph(domain_for(58))
    graph.env[CACHE_ENVIRONMENT] = str(cache)
    try:
        bringup = graph.start('facade', '--facade', str(structural_facade_file), '--start',
                              '11:00', '--end', '11:20', '--speedup', '120',
                              '--panel-processes', '2', '--progress-period', '2')
        output, _ = bringup.communicate(timeout=240)
    finally:
        graph.close()
    assert bringup.returncode == 0, output
    closed_kpa = cushion_map.tables()[0][0][-1] / 1e3
    assert (f'facade: structural cushion map of small (median panel r01c00), cached: closed at '
            f'{closed_kpa:.2f} kPa') in output
    assert 'small: day finished at 2026-06-21 11:20 (local)' in output
    assert 'panels reporting: 4/4' in output and 'Traceback' not in output
