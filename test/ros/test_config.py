"""The example parameter files under config/ name only real parameters, with valid values."""

from pathlib import Path

import pytest
from rcl_interfaces.msg import ParameterType
import yaml

from flectofold_ros.nodes import (bag_recorder, coordinator, facade_markers, panel, rerun_bridge,
                                  sun_position)
from flectofold_ros.wire import contract

CONFIG = Path(__file__).resolve().parents[2] / 'config'
#: config file -> the parameters of the node it is for.
FILES = {'panel.yaml': panel.PARAMETERS, 'coordinator.yaml': coordinator.PARAMETERS,
         'sun_position.yaml': sun_position.PARAMETERS,
         'rerun_bridge.yaml': rerun_bridge.PARAMETERS,
         'bag_recorder.yaml': bag_recorder.PARAMETERS,
         'facade_markers.yaml': facade_markers.PARAMETERS}
#: Files under config/ that are not parameter files: Modbus register maps.
REGISTER_MAPS = ('modbus_terminal.yaml', 'modbus_regulators.yaml')
#: rclpy's own parameter, which every node has.
BUILT_IN = {'use_sim_time': ParameterType.PARAMETER_BOOL}
PYTHON_TYPES = {ParameterType.PARAMETER_BOOL: bool, ParameterType.PARAMETER_DOUBLE: float,
                ParameterType.PARAMETER_INTEGER: int, ParameterType.PARAMETER_STRING: str,
                ParameterType.PARAMETER_STRING_ARRAY: list}


def test_every_config_file_is_checked_here():
    assert sorted(path.name for path in CONFIG.glob('*.yaml')) == sorted(
        [*FILES, *REGISTER_MAPS])


@pytest.mark.parametrize('name', REGISTER_MAPS)
def test_a_register_map_under_config_loads(name):
    from flectofold_ros.hardware.register_map import load_register_map
    assert load_register_map(CONFIG / name).count >= 1


@pytest.mark.parametrize('name', sorted(FILES))
def test_a_config_file_sets_declared_parameters_to_valid_values(name):
    specs = FILES[name]
    document = yaml.safe_load((CONFIG / name).read_text())
    (parameters,) = [section['ros__parameters'] for section in document.values()]
    assert parameters, name
    for key, value in parameters.items():
        if key in BUILT_IN:
            assert type(value) is PYTHON_TYPES[BUILT_IN[key]], key
            continue
        assert key in specs, f'{name}: {key} is not a parameter of the node'
        descriptor = specs[key].descriptor
        assert type(value) is PYTHON_TYPES[descriptor.type], (key, value)
        for bounds in (*descriptor.floating_point_range, *descriptor.integer_range):
            assert bounds.from_value <= value <= bounds.to_value, (key, value)
        if specs[key].choices:
            assert value in specs[key].choices, (key, value)


def test_the_panel_file_lists_every_panel_parameter_at_its_default():
    document = yaml.safe_load((CONFIG / 'panel.yaml').read_text())
    parameters = document['/**']['ros__parameters']
    assert parameters == {name: spec.default for name, spec in panel.PARAMETERS.items()
                          if name != 'panel_id'}


def test_the_rviz_config_shows_the_markers_topic_in_the_site_frame():
    document = yaml.safe_load((CONFIG / 'facade.rviz').read_text())
    manager = document['Visualization Manager']
    assert manager['Global Options']['Fixed Frame'] == contract.SITE_FRAME
    (display,) = [d for d in manager['Displays']
                  if d['Class'] == 'rviz_default_plugins/MarkerArray']
    assert display['Topic']['Value'] == contract.MARKERS.name
    # a volatile or best-effort subscription would still match; this one gets the latched one
    assert display['Topic']['Durability Policy'] == 'Transient Local'
    assert set(display['Namespaces']) == {'panels', 'surface', 'sun'}


def test_the_foxglove_layout_shows_the_markers_topic_in_the_site_frame():
    import json
    layout = json.loads((CONFIG / 'facade.foxglove.json').read_text())
    three_d = layout['configById'][layout['layout']['first']]
    assert three_d['followTf'] == contract.SITE_FRAME
    assert three_d['topics'] == {contract.MARKERS.name: {'visible': True}}
    assert layout['configById'][layout['layout']['second']]['topicToRender'] == \
        contract.DIAGNOSTICS.name
