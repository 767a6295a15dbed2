"""``replay`` stopped by Ctrl-C or SIGTERM to its process group at the moments that matter.

The moments: importing rclpy (after the command has loaded, before the player starts),
converting a bag that takes seconds to an .rrd, and playing a bag at a fast rate. Each replay
leads its own process group, with SIGINT at its default as in a terminal's foreground job.
"""

import os
from pathlib import Path
import signal
import subprocess
import time

from builtin_interfaces.msg import Time
import numpy as np
import pytest
from rclpy.serialization import serialize_message
from ros_graph import BIN, domain_for, Graph, PROMPT_S, signal_group_and_wait
from rrd_reading import Rrd
from sensor_msgs.msg import PointCloud2, PointField

from flectofold_model.actuation import ATMOSPHERIC_PRESSURE_PA
from flectofold_model.facade.description import DEFAULT_FACADE, load_facade
from flectofold_ros.recording import SegmentedBagWriter
from flectofold_ros.runtime.interfaces import subscription
from flectofold_ros.wire import contract, panel_states

pytestmark = pytest.mark.graph
#: States in the bag: 1 s apart; converting them takes several seconds.
STATES = 800
T0_NS = 1782036000 * 10**9


@pytest.fixture(scope='module')
def day_bag(tmp_path_factory):
    """Write a bag of the demonstrator's panel states, every panel moving every second."""
    facade = load_facade(DEFAULT_FACADE)
    rows, columns = panel_states.id_numbers(facade.panel_ids)
    origins = facade.origin_m @ facade.facade_to_enu.T
    path = tmp_path_factory.mktemp('bags') / 'day'
    with SegmentedBagWriter(path) as writer:
        writer.add_topic(contract.PANEL_STATES.name, contract.PANEL_STATES.msgtype)
        for step in range(STATES):
            closure = 0.5 + 0.45 * np.sin(step / 20.0 + np.arange(len(facade)) / 5.0)
            table = panel_states.new_table(len(facade))
            table['x'], table['y'], table['z'] = origins.T  # where the facade puts each panel
            table['closure'] = table['setpoint'] = table['fold_angle_rad'] = closure
            table['pressure_pa'] = ATMOSPHERIC_PRESSURE_PA + 8e3 * closure
            table['row'], table['column'] = rows, columns
            t_ns = T0_NS + step * 10**9
            message = panel_states.fill_message(PointCloud2(), table, Time(sec=t_ns // 10**9),
                                                PointField)
            writer.write(contract.PANEL_STATES.name, t_ns, serialize_message(message))
    return path


def foreground():
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def start_replay(*arguments):
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain_for(49)), PYTHONUNBUFFERED='1',
               RCUTILS_COLORIZED_OUTPUT='0', ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    return subprocess.Popen([str(BIN / 'replay'), *map(str, arguments)], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True, preexec_fn=foreground)


def wait_until(condition, timeout_s=60.0, period_s=0.005):
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, 'the moment never came'
        time.sleep(period_s)


def maps(process):
    try:
        return Path(f'/proc/{process.pid}/maps').read_text()
    except OSError:
        return ''


def stop(process, number, expected_code):
    """Signal the group; check a prompt, clean exit; return the output."""
    code, output, took_s = signal_group_and_wait(process, number)
    assert code == expected_code, output
    assert took_s < PROMPT_S, (took_s, output)
    for word in ('Traceback', 'FATAL', 'KeyboardInterrupt', 'Interrupted'):
        assert word not in output, output
    return output


@pytest.mark.parametrize('number', [signal.SIGINT, signal.SIGTERM])
def test_a_stop_while_rclpy_loads_is_clean(day_bag, number):
    replay = start_replay(day_bag)
    # rclpy's C library is mapped: the player's imports are under way.
    wait_until(lambda: '_rclpy_pybind11' in maps(replay) or replay.poll() is not None)
    stop(replay, number, 0)


def test_ctrl_c_while_converting_is_clean_and_leaves_a_readable_rrd(day_bag, tmp_path):
    rrd_path = tmp_path / 'day.rrd'
    replay = start_replay(day_bag, '--to-rrd', rrd_path)
    # converting: past the static scene (some 40 kB), the meshes of the first states
    wait_until(lambda: rrd_path.exists() and rrd_path.stat().st_size > 10**6)
    stop(replay, signal.SIGINT, 130)
    rrd = Rrd(rrd_path)
    assert {'/facade/panels', '/metrics/closure'} <= rrd.entities()
    assert 0 < len(rrd.meshes()) < STATES  # what was converted, not the whole day


@pytest.mark.parametrize('number', [signal.SIGINT, signal.SIGTERM])
def test_a_stop_while_playing_fast_is_clean(day_bag, number):
    graph = Graph(domain_for(49))  # a listener: the replay's domain
    try:
        heard = []
        subscription(graph.node, contract.PANEL_STATES, heard.append, contract.REPLAY)
        replay = start_replay(day_bag, '--rate', '200')  # the day's 800 s in 4 s
        # playing: its first states arrived
        assert graph.spin_until(lambda: heard or replay.poll() is not None, 60.0)
        output = stop(replay, number, 0)
    finally:
        graph.close()
    published = int(output.split('replay: ')[1].split(' messages')[0])
    assert 0 < published < STATES, output
