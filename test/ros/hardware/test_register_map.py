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


def test_a_key_given_twice_is_refused_naming_both_lines(tmp_path):
    # On a shared bus a second unit_id, read last-wins, addresses another device.
    text = EXAMPLE.read_text()
    twice = tmp_path / 'twice.yaml'
    twice.write_text(text + 'unit_id: 7\n')
    first = 1 + next(number for number, line in enumerate(text.splitlines())
                     if line.startswith('unit_id:'))
    last = len(text.splitlines()) + 1
    with pytest.raises(RegisterMapError) as refused:
        load_register_map(twice)
    assert str(refused.value) == (
        f"{twice}: line {last}, column 1: key 'unit_id' given twice (first at line {first}, "
        f'column 1); one value would silently win')


REGULATORS = Path(__file__).resolve().parents[3] / 'config' / 'modbus_regulators.yaml'


def _regulated(**regulator):
    """Return a map of a valve channel (outputs 10, 11) and a regulator channel (output 12)."""
    document = _map()
    document['channels'].append({
        'regulator': {'address': 12, 'gauge_pa_per_count': 2.0, 'max_count': 10000,
                      **regulator},
        'pressure': {'address': 6, 'pa_per_count': 1.0, 'offset_pa': 101325.0},
        'supply': {'address': 7, 'pa_per_count': 2.0, 'offset_pa': 101325.0}})
    return document


def test_the_example_regulator_map_loads_two_regulators_in_one_output_block():
    register_map = load_register_map(REGULATORS)
    assert register_map.regulated.tolist() == [True, True]
    assert (register_map.output_start, register_map.output_count) == (0, 2)
    assert register_map.encode_outputs([0.0, 0.0], [0.0, 0.0], [5000.0, 0.0]) == [2500, 0]


def test_a_mixed_map_writes_openings_and_setpoints_in_one_block():
    register_map = parse(_regulated())
    assert register_map.regulated.tolist() == [False, True]
    assert (register_map.output_start, register_map.output_count) == (10, 3)
    block = register_map.encode_outputs([0.25, 0.0], [0.0, 1.0], [0.0, 4323.0])
    assert block == [2500, 0, 2161]  # 4323 Pa rounds down to 2161 counts of 2 Pa
    fill, vent = register_map.decode_outputs(block)
    assert fill[0] == 0.25 and vent[0] == 0.0 and np.isnan(fill[1]) and np.isnan(vent[1])
    setpoint = register_map.decode_setpoints(block)
    assert np.isnan(setpoint[0]) and setpoint[1] == 4322.0
    with pytest.raises(ValueError, match='setpoints are needed'):
        register_map.encode_outputs([0.0, 0.0], [0.0, 0.0])


def test_a_setpoint_is_clipped_to_the_regulator_range_and_never_rounded_up():
    regulator = parse(_regulated(gauge_offset_pa=-1.5)).channels[1].regulator
    assert int(regulator.encode(0.0)) == 0  # count 0.75: down to 0 (-1.5 Pa), not up to 0.5 Pa
    assert int(regulator.encode(1e6)) == 10000 and int(regulator.encode(-50.0)) == 0
    signed = parse(_regulated(signed=True, min_count=-100, gauge_offset_pa=0.0))
    raw = int(signed.channels[1].regulator.encode(-100.0))
    assert raw == 65536 - 50 and signed.decode_setpoints([0, 0, raw])[1] == -100.0


def test_the_terminal_side_takes_only_counts_in_each_outputs_range():
    register_map = parse(_regulated())
    assert register_map.outputs_take(10, [10000, 0, 10000])
    assert not register_map.outputs_take(12, [10001])  # past the regulator's max_count
    assert not register_map.outputs_take(10, [10001])  # past full_open
    assert not register_map.outputs_take(12, [0, 0])  # address 13 is no output


@pytest.mark.parametrize('change, message', [
    (lambda c: c.update(fill=13), 'channels\\[1\\].fill must be absent beside a regulator'),
    (lambda c: c.pop('regulator'), 'channels\\[1\\].fill is missing .*or a regulator'),
    (lambda c: c['regulator'].update(address=11), 'channels\\[1\\].regulator.address must be '
     'an address of its own, not that of channels\\[0\\].vent'),
    (lambda c: c['regulator'].update(address=13), 'channels must be one contiguous block'),
    (lambda c: c['regulator'].update(gauge_offset_pa=10.0),
     'channels\\[1\\].regulator.min_count must be a count of at most 0 Pa gauge'),
    (lambda c: c['regulator'].update(gauge_offset_pa=-30000.0),
     'channels\\[1\\].regulator.max_count must be a count above 0 Pa gauge'),
    (lambda c: c['regulator'].update(gauge_pa_per_count=0.0),
     'channels\\[1\\].regulator.gauge_pa_per_count must be a number in'),
    (lambda c: c['regulator'].pop('gauge_pa_per_count'),
     'channels\\[1\\].regulator.gauge_pa_per_count is missing'),
    (lambda c: c['regulator'].update(pa_per_count=2.0),
     'unknown key channels\\[1\\].regulator.pa_per_count'),
    (lambda c: c['regulator'].update(min_count=9, max_count=9),
     'channels\\[1\\].regulator.max_count must be more than'),
    (lambda c: c.update(regulator=12), 'channels\\[1\\].regulator must be a mapping'),
])
def test_a_malformed_regulator_channel_is_refused_naming_the_key(change, message):
    document = _regulated()
    change(document['channels'][1])
    with pytest.raises(RegisterMapError, match=f'^map.yaml: {message}'):
        parse(document, 'map.yaml')


def test_a_regulator_on_a_coil_table_is_refused():
    document = _regulated()
    document['outputs'] = {'table': 'coils'}
    with pytest.raises(RegisterMapError, match='map.yaml: outputs.table must be '
                                               'holding_registers: channels\\[1\\].regulator'):
        parse(document, 'map.yaml')


def test_a_regulator_may_not_share_a_holding_register_with_an_input():
    document = _regulated()
    document['inputs'] = {'table': 'holding_registers'}
    document['channels'][0]['supply']['address'] = 12
    with pytest.raises(RegisterMapError, match='channels.*an input or an output, not both'):
        parse(document, 'map.yaml')
