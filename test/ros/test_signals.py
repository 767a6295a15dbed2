"""Every executable stopped by a signal as a terminal sends it: to its whole process group.

Ctrl-C in a terminal sends SIGINT to every process of the foreground group at once; a service
manager sends SIGTERM. At any moment, loading or running, an executable must exit cleanly:
its exit code, no traceback, no ``[FATAL]`` line, no process of its group left behind.
"""

import os
from pathlib import Path
import signal
import subprocess
import time

import pytest
from ros_graph import BIN, domain_for, signal_group_and_wait
from rosbags.rosbag2 import Reader

from flectofold_ros.recording import SegmentedBagWriter
from flectofold_ros.wire import contract

pytestmark = pytest.mark.graph
#: Seconds after the executable's stop handlers are in place: still loading (imports,
#: models), and up and running. Counted from the handlers, not from the process's start: before
#: its first line runs, the interpreter's own start (under a second on an idle machine, longer
#: on a loaded one) answers SIGINT with Python's KeyboardInterrupt, which no program can change.
MOMENTS_S = (0.4, 4.0)
#: Longest wait for an executable's first line [s]: a safety net for a loaded machine.
FIRST_LINE_S = 60.0


@pytest.fixture(scope='module')
def long_bag(tmp_path_factory):
    """Write a bag of two /clock messages an hour apart: replay still plays when stopped."""
    from rosbags.typesys import get_typestore, Stores
    store = get_typestore(Stores.ROS2_JAZZY)
    path = tmp_path_factory.mktemp('bags') / 'hour'
    with SegmentedBagWriter(path) as writer:
        writer.add_topic(contract.CLOCK.name, contract.CLOCK.msgtype)
        for t_s in (1.0, 3601.0):
            message = store.types['rosgraph_msgs/msg/Clock'](
                clock=store.types['builtin_interfaces/msg/Time'](sec=int(t_s), nanosec=0))
            writer.write(contract.CLOCK.name, int(t_s * 1e9),
                         store.serialize_cdr(message, 'rosgraph_msgs/msg/Clock').tobytes())
    return path


def arguments(name, tmp_path, small_facade, long_bag):
    return {
        'panel_node': ['--ros-args', '-r', '__ns:=/facade/r00c00'],
        'panel_group': ['--panels', 'r00c00,r00c01'],
        'sun_position_node': ['--ros-args', '-p', 'mode:=simulated'],
        'coordinator_node': [],
        'rerun_bridge': ['--ros-args', '-p', 'viewer:=none', '-p',
                         f'rrd_path:={tmp_path / "x.rrd"}'],
        'bag_recorder': ['--ros-args', '-p', f'output:={tmp_path / "bag"}'],
        'replay': [str(long_bag)],
        'facade': ['--facade', str(small_facade), '--speedup', '60', '--panel-processes', '1',
                   '--record', '--rerun', 'none', '--out', str(tmp_path / 'out')],
        'day_report': ['--out', str(tmp_path)],
    }[name]


#: Exit code when stopped: nodes end as asked (0); a day or a report was cut short (130).
EXPECTED = {'facade': 130, 'day_report': 130}


@pytest.fixture
def small_facade(tmp_path, small_facade_text):
    path = tmp_path / 'small.yaml'
    path.write_text(small_facade_text('shading_target: 0.9'))
    return path


def catches_sigterm(pid):
    """Whether process ``pid`` has a handler for SIGTERM (``SigCgt`` of ``/proc/PID/status``).

    Python installs none of its own: the executable's stop handlers
    (:class:`~flectofold_ros.runtime.runner.StopSignals`, its first act) are in place.
    """
    try:
        status = Path(f'/proc/{pid}/status').read_text()
    except OSError:
        return False
    caught = next(line.split()[1] for line in status.splitlines() if line.startswith('SigCgt:'))
    return bool(int(caught, 16) >> (signal.SIGTERM - 1) & 1)


def run_and_signal(command, delay_s, number, environment):
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               text=True, env=environment, start_new_session=True)
    deadline = time.monotonic() + FIRST_LINE_S
    while not catches_sigterm(process.pid) and process.poll() is None \
            and time.monotonic() < deadline:
        time.sleep(0.005)
    time.sleep(delay_s)
    _, output, _ = signal_group_and_wait(process, number, timeout_s=60.0)
    survivors = subprocess.run(['pgrep', '-g', str(process.pid)], capture_output=True,
                               text=True).stdout.split()
    if survivors:
        os.killpg(process.pid, signal.SIGKILL)
    return process.returncode, output, survivors


@pytest.mark.parametrize('delay_s', MOMENTS_S)
@pytest.mark.parametrize('name', ['panel_node', 'panel_group', 'sun_position_node',
                                  'coordinator_node', 'rerun_bridge', 'bag_recorder', 'replay',
                                  'facade', 'day_report'])
def test_ctrl_c_to_the_group_exits_cleanly_at_any_moment(name, delay_s, tmp_path, small_facade,
                                                         long_bag):
    environment = dict(os.environ, ROS_DOMAIN_ID=str(domain_for(30)), PYTHONUNBUFFERED='1',
                       RCUTILS_COLORIZED_OUTPUT='0')
    command = [str(BIN / name), *arguments(name, tmp_path, small_facade, long_bag)]
    code, output, survivors = run_and_signal(command, delay_s, signal.SIGINT, environment)
    assert code == EXPECTED.get(name, 0), output
    for word in ('Traceback', 'FATAL', 'KeyboardInterrupt'):
        assert word not in output, output
    assert not survivors, output
    if name == 'bag_recorder' and (tmp_path / 'bag').exists():
        with Reader(tmp_path / 'bag') as reader:  # a bag that was begun is a valid bag
            assert reader.message_count >= 0


def test_sigterm_to_the_group_as_a_service_manager_stops_it(tmp_path, small_facade, long_bag):
    environment = dict(os.environ, ROS_DOMAIN_ID=str(domain_for(31)), PYTHONUNBUFFERED='1')
    command = [str(BIN / 'panel_group'), '--panels', 'r00c00,r00c01']
    code, output, survivors = run_and_signal(command, 5.0, signal.SIGTERM, environment)
    assert code == 0 and 'Traceback' not in output and not survivors, output


def test_python_m_flectofold_ros_runs_an_executable():
    run = subprocess.run([str(Path(BIN) / 'python'), '-m', 'flectofold_ros', 'fold_table',
                          '--steps', '2'], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0 and 'closure' in run.stdout, run.stderr
    wrong = subprocess.run([str(Path(BIN) / 'python'), '-m', 'flectofold_ros', 'nonsense'],
                           capture_output=True, text=True, timeout=60)
    assert wrong.returncode == 2 and 'usage' in wrong.stderr


KILLED_RECORDING = """
import os, sys
from rosbags.typesys import get_typestore, Stores
from flectofold_ros.recording import SegmentedBagWriter
ts = get_typestore(Stores.ROS2_JAZZY)
writer = SegmentedBagWriter(sys.argv[1], max_segment_s=1.0)
writer.add_topic('/setpoint', 'std_msgs/msg/Float64')
for i in range(20000):  # 0.1 ms steps: one closed segment of 10 000, then an open one
    msg = ts.types['std_msgs/msg/Float64'](float(i))
    writer.write('/setpoint', 100_000 * i, ts.serialize_cdr(msg, 'std_msgs/msg/Float64'))
writer.flush()
os._exit(1)
"""


@pytest.mark.parametrize('delay_s', MOMENTS_S)
def test_ctrl_c_to_bag_reindex_leaves_a_bag_the_next_one_finishes(tmp_path, delay_s):
    bag = tmp_path / 'killed'
    subprocess.run([str(BIN / 'python'), '-c', KILLED_RECORDING, str(bag)], timeout=120)
    command = [str(BIN / 'bag_reindex'), str(bag)]
    code, output, survivors = run_and_signal(command, delay_s, signal.SIGINT, dict(os.environ))
    assert code in (0, 130) and 'Traceback' not in output and not survivors, output
    again = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert again.returncode == 0, again.stderr
    from rosbags.typesys import get_typestore, Stores
    store = get_typestore(Stores.ROS2_JAZZY)
    with Reader(bag) as reader:
        assert reader.message_count == 20000
        assert sorted(int(store.deserialize_cdr(raw, 'std_msgs/msg/Float64').data)
                      for _, _, raw in reader.messages()) == list(range(20000))
