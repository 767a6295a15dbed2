"""The register map of a Modbus valve terminal: validation, scaling, block layout."""

from pathlib import Path

import numpy as np
import pytest

from flectofold_ros.hardware.register_map import (load_register_map, parse, RegisterMapError)

EXAMPLE = Path(__file__).resolve().parents[3] / 'config' / 'modbus_terminal.yaml'


def _map(**changes):
    document = {
        'unit_id': 1, 'outputs': {'table': 'holding_registers', 'full_open': 10000},
        'inputs': {'table': 'input_registers'},
        'channels': [{'fill': 10, 'vent': 11,
                      'pressure': {'address': 5, 'pa_per_count': 1.0, 'offset_pa': 101325.0,
                                   'signed': True, 'min_count': -5000, 'max_count': 30000},
                      'supply': {'address': 7, 'pa_per_count': 2.0, 'offset_pa': 101325.0}}]}
    document.update(changes)
    return document


def test_the_example_map_loads_two_channels_in_one_block_each():
    register_map = load_register_map(EXAMPLE)
    assert register_map.count == 2 and register_map.unit_id == 1
    assert (register_map.output_start, register_map.output_count) == (0, 4)
    assert (register_map.input_start, register_map.input_count) == (0, 3)


def test_counts_scale_to_absolute_pascals_and_back():
    register_map = parse(_map())
    block = register_map.encode_inputs([101325.0 + 4321.0], [101325.0 + 50000.0])
    assert block.tolist() == [4321, 0, 25000]  # addresses 5, (6 unused), 7
    pressure, supply = register_map.decode_inputs(block)
    np.testing.assert_allclose(pressure, [105646.0])
    np.testing.assert_allclose(supply, [151325.0])


def test_a_signed_register_reads_below_the_offset():
    register_map = parse(_map())
    pressure, _ = register_map.decode_inputs([65536 - 40, 0, 25000])  # int16 -40
    np.testing.assert_allclose(pressure, [101325.0 - 40.0])


@pytest.mark.parametrize('raw', [30001, 65536 - 5001, 32767])
def test_a_count_outside_the_valid_range_reads_nan(raw):
    pressure, supply = parse(_map()).decode_inputs([raw, 0, 25000])
    assert np.isnan(pressure[0]) and np.isfinite(supply[0])


def test_encoding_clips_a_pressure_beyond_the_range_and_a_nan_to_the_lowest_count():
    sensor = parse(_map()).channels[0].pressure
    assert int(sensor.encode(1e7)) == 30000
    assert int(sensor.encode(np.nan)) == 65536 - 5000


def test_openings_become_scaled_holding_registers_and_coils():
    assert parse(_map()).encode_outputs([0.25], [1.0]) == [2500, 10000]
    coils = parse(_map(outputs={'table': 'coils'}))
    assert coils.encode_outputs([0.49], [0.5]) == [False, True]


def test_a_holding_register_above_full_open_reads_the_safe_side():
    fill, vent = parse(_map()).decode_outputs([12000, 12000])
    assert fill[0] == 0.0 and vent[0] == 1.0


@pytest.mark.parametrize('changes, key', [
    ({'unit_id': 0}, 'unit_id'),
    ({'unit_id': 'one'}, 'unit_id'),
    ({'outputs': {'table': 'registers'}}, 'outputs.table'),
    ({'outputs': {'table': 'holding_registers', 'full_open': 0}}, 'outputs.full_open'),
    ({'inputs': {'table': 'coils'}}, 'inputs.table'),
    ({'fail_safe': {'timeout_s': -1}}, 'fail_safe.timeout_s'),
    ({'channels': []}, 'channels'),
    ({'extra': 1}, 'extra'),
    ({'outputs': None}, 'outputs'),
])
def test_a_malformed_map_is_refused_naming_the_key(changes, key):
    with pytest.raises(RegisterMapError, match=f'map.yaml: .*{key}'):
        parse(_map(**changes), 'map.yaml')


@pytest.mark.parametrize('channel, key, why', [
    ({'fill': 10, 'vent': 10}, 'channels\\[0\\].vent', 'an address of its own'),
    ({'fill': 10, 'vent': 12}, 'channels', 'contiguous'),
    ({'fill': -1}, 'channels\\[0\\].fill', 'integer in'),
    ({'pressure': {'address': 5, 'pa_per_count': 0.0, 'offset_pa': 0.0}},
     'channels\\[0\\].pressure.pa_per_count', 'number in'),
    ({'pressure': {'address': 5, 'pa_per_count': float('nan'), 'offset_pa': 0.0}},
     'channels\\[0\\].pressure.pa_per_count', 'number in'),
    ({'pressure': {'address': 5, 'pa_per_count': 1.0}}, 'channels\\[0\\].pressure.offset_pa',
     'missing'),
    ({'pressure': {'address': 5, 'pa_per_count': 1.0, 'offset_pa': 0.0, 'min_count': 9,
                   'max_count': 9}}, 'channels\\[0\\].pressure.max_count', 'more than'),
    ({'pressure': {'address': 5, 'pa_per_count': 1.0, 'offset_pa': 0.0, 'signed': 'yes'}},
     'channels\\[0\\].pressure.signed', 'true or false'),
    ({'supply': {'address': 300, 'pa_per_count': 1.0, 'offset_pa': 0.0}}, 'channels',
     'at most 125'),
    ({'fill': 5, 'vent': 6}, None, None),  # holding-register inputs below: shared 5
])
def test_a_malformed_channel_is_refused_naming_the_key(channel, key, why):
    document = _map()
    document['channels'][0].update(channel)
    if key is None:
        document['inputs'] = {'table': 'holding_registers'}
        key, why = 'channels', 'an input or an output, not both'
    with pytest.raises(RegisterMapError, match=f'{key}.*{why}'):
        parse(document, 'map.yaml')


def test_two_channels_may_not_read_one_cushion_sensor():
    document = _map()
    document['channels'].append(dict(document['channels'][0], fill=12, vent=13))
    with pytest.raises(RegisterMapError, match='channels\\[1\\].pressure.address'):
        parse(document)


def test_a_file_that_cannot_be_read_or_is_not_yaml_is_refused(tmp_path):
    with pytest.raises(RegisterMapError, match='cannot be read'):
        load_register_map(tmp_path / 'missing.yaml')
    bad = tmp_path / 'bad.yaml'
    bad.write_text('unit_id: [1\n')
    with pytest.raises(RegisterMapError, match='bad.yaml'):
        load_register_map(bad)
