"""``/facade/panel_states``: packed by the panel processes, read back by rosbags and numpy."""

from builtin_interfaces.msg import Time
import numpy as np
import pytest
from rclpy.serialization import serialize_message
from sensor_msgs.msg import PointCloud2, PointField

from flectofold_ros.rerun.bag_to_rrd import decode
from flectofold_ros.wire import contract, panel_states

IDS = ['r00c00', 'r00c01', 'r12c07', 'r24c39']


def _message(table):
    return panel_states.fill_message(PointCloud2(), table, Time(sec=7, nanosec=5), PointField)


@pytest.fixture
def table():
    table = panel_states.new_table(len(IDS))
    table['row'], table['column'] = panel_states.id_numbers(IDS)
    table['closure'] = [0.0, 0.25, 0.5, 1.0]
    table['pressure_pa'] = [101325.0, np.nan, 103000.5, 110000.0]
    table['fault'] = [0, 3, 0, 6]
    table['status'] = [0, 3, 1, 2]
    table['x'] = [1.5, -2.0, 3.25, 40.0]
    return table


def test_a_cloud_read_back_by_rosbags_gives_the_table(table):
    raw = serialize_message(_message(table))
    message = decode(bytes(raw), contract.PANEL_STATES.msgtype)  # rosbags' typestore
    back = panel_states.unpack(message)
    assert panel_states.panel_ids(back) == IDS
    np.testing.assert_array_equal(back['closure'], table['closure'])
    np.testing.assert_array_equal(back['pressure_pa'], table['pressure_pa'])  # NaN kept
    assert panel_states.fault_words(back) == ['none', 'leak', 'none', 'overpressure']
    assert panel_states.status_words(back) == ['waiting_for_setpoint', 'fault', 'tracking',
                                               'setpoint_timeout']
    assert panel_states.stamp_ns(message.header) == 7 * 10**9 + 5
    assert message.header.frame_id == contract.SITE_FRAME
    assert [f.name for f in message.fields][:3] == ['x', 'y', 'z']  # RViz draws it as is


def test_the_layout_is_what_the_doc_says():
    offsets = {name: panel_states.DTYPE.fields[name][1] for name, _, _ in panel_states.FIELDS}
    assert offsets == {'x': 0, 'y': 4, 'z': 8, 'closure': 12, 'fold_angle_rad': 16,
                       'pressure_pa': 20, 'setpoint': 24, 'row': 28, 'column': 30,
                       'fault': 32, 'status': 33, 'active': 34}
    assert panel_states.POINT_STEP == 36


def test_a_foreign_cloud_is_refused_not_misread(table):
    message = _message(table)
    message.fields = message.fields[:3]  # a plain xyz cloud on the topic
    with pytest.raises(ValueError, match='fields'):
        panel_states.unpack(message)
    message = _message(table)
    message.data = bytes(message.data)[:-1]
    with pytest.raises(ValueError, match='bytes'):
        panel_states.unpack(message)
    message = _message(table)
    message.is_bigendian = True
    with pytest.raises(ValueError, match='little endian'):
        panel_states.unpack(message)


def test_unknown_codes_read_as_unknown(table):
    table['fault'][0] = 200
    assert panel_states.fault_words(table)[0] == 'unknown'


def test_indices_map_ids_and_mark_strangers(table):
    lookup = panel_states.index_lookup(['r24c39', 'r00c01'])
    assert panel_states.indices(table, lookup).tolist() == [-1, 1, -1, 0]
    table['row'][0], table['column'][2] = 65535, 100  # a hostile cloud: no such ids
    assert panel_states.indices(table, lookup).tolist() == [-1, 1, -1, 0]


@pytest.mark.parametrize('bad', ['r1c1', 'panel', 'r00c001'])
def test_ids_must_be_of_the_contract_form(bad):
    with pytest.raises(ValueError, match='rNNcNN'):
        panel_states.id_numbers([bad])
