"""The package driven by the real ROS 2 tools: ``ros2 launch``, ``ros2 param``, ``ros2 topic``.

ros2cli, launch and launch_ros are pure Python but not on PyPI. Where this clone sits next to
``../shared/ros2-tools`` (the project's machines), ``install.sh`` there installs them into a venv
of their own; that venv sees the project's venv (rclpy, the package) through a ``.pth`` line,
and the package is found by ``ros2`` through an ament prefix laid out as ``colcon build
--symlink-install`` lays it out (the resource index entry, ``share/flectofold_ros`` with
``package.xml`` and the launch file, ``lib/flectofold_ros`` with the executables; the colcon
layout itself is tested in ``test_package.py``). Elsewhere the tests skip and say why.
"""

import os
from pathlib import Path
import signal
import subprocess
import sys
import sysconfig

import numpy as np
import pytest
from ros_graph import BIN, domain_for, Graph
from std_msgs.msg import Float64

from flectofold_ros.runtime.executables import EXECUTABLES
from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.wire import contract, panel_states

pytestmark = pytest.mark.graph
ROOT = Path(__file__).resolve().parents[2]
INSTALL = ROOT.parent / 'shared' / 'ros2-tools' / 'install.sh'
PACKAGE = 'flectofold_ros'


class Ros2Tools:
    """The real ``ros2`` in a venv of its own, and the environment it finds the package in."""

    def __init__(self, venv, prefix):
        self.ros2 = str(venv / 'bin' / 'ros2')
        self.prefix = prefix

    def environment(self, graph):
        """Return the environment of ``graph`` (its domain), the package's prefix first."""
        return dict(graph.env, AMENT_PREFIX_PATH=os.pathsep.join(
            [str(self.prefix), os.environ.get('AMENT_PREFIX_PATH', sys.prefix)]))

    def start(self, graph, *arguments):
        """Start ``ros2 ARGUMENTS`` as the leader of a new process group, as a terminal does."""
        process = subprocess.Popen([self.ros2, *arguments], env=self.environment(graph),
                                   stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                   start_new_session=True)
        process.flectofold_group = True
        graph.processes.append(process)
        return process

    def run(self, graph, *arguments, timeout_s=60.0, tries=5):
        """Run ``ros2 ARGUMENTS`` to its end; return the completed process.

        Without the daemon each call discovers the graph afresh and may not see the node yet
        (``Node not found``): then it is asked again, as a user would.
        """
        for _ in range(tries):
            run = subprocess.run([self.ros2, *arguments], env=self.environment(graph),
                                 capture_output=True, text=True, timeout=timeout_s)
            if 'Node not found' not in run.stderr:
                break
        return run


def _ament_prefix(prefix):
    index = prefix / 'share' / 'ament_index' / 'resource_index' / 'packages'
    share, lib = prefix / 'share' / PACKAGE, prefix / 'lib' / PACKAGE
    for folder in (index, share / 'launch', lib):
        folder.mkdir(parents=True)
    (index / PACKAGE).touch()
    (share / 'package.xml').symlink_to(ROOT / 'package.xml')
    for launch_file in (ROOT / 'launch').glob('*launch.py'):
        (share / 'launch' / launch_file.name).symlink_to(launch_file)
    for name in EXECUTABLES:
        (lib / name).symlink_to(BIN / name)
    return prefix


@pytest.fixture(scope='module')
def ros2_tools(tmp_path_factory):
    if not INSTALL.is_file():
        pytest.skip(f'the real ros2 CLI and launch are installed by {INSTALL}, which is not '
                    'next to this clone (users install ROS 2 themselves)')
    base = tmp_path_factory.mktemp('ros2_tools')
    venv = base / 'venv'
    subprocess.run([sys.executable, '-m', 'venv', str(venv)], check=True, timeout=300)
    own_site = Path(sysconfig.get_paths()['purelib'])
    site = next((venv / 'lib').glob('python3*/site-packages'))
    (site / 'flectofold_venv.pth').write_text(f'import site; site.addsitedir({str(own_site)!r})\n')
    # This process's environment carries the ROS wheels' library path to install.sh's checks.
    installed = subprocess.run(['bash', str(INSTALL), str(venv)], capture_output=True,
                               text=True, timeout=600)
    assert installed.returncode == 0, installed.stdout + installed.stderr
    return Ros2Tools(venv, _ament_prefix(base / 'prefix'))


def _states(graph):
    """Subscribe to /facade/panel_states; return the latest table per panel id, as it comes."""
    latest = {}

    def on_states(message):
        table = panel_states.unpack(message)
        for panel_id, row in zip(panel_states.panel_ids(table), table):
            latest[panel_id] = row
    subscription(graph.node, contract.PANEL_STATES, on_states, contract.OBSERVER)
    return latest


def _tracking(latest, panel_ids, tolerance=0.05):
    tracking = contract.STATUSES.index('tracking')
    return len(latest) == len(panel_ids) and all(
        latest[p]['status'] == tracking and abs(latest[p]['closure'] - latest[p]['setpoint'])
        < tolerance for p in panel_ids)


def test_ros2_launch_brings_a_facade_up_tracks_and_stops_on_ctrl_c(ros2_tools, tmp_path,
                                                                   small_facade_text):
    facade_file = tmp_path / 'small.yaml'
    facade_file.write_text(small_facade_text('period_s: 60.0, shading_target: 0.9, '
                                             'min_dwell_s: 300.0, default_closure: 1.0'))
    graph = Graph(domain_for(22))
    try:
        latest = _states(graph)
        launch = ros2_tools.start(graph, 'launch', PACKAGE, 'facade.launch.py',
                                  f'facade_file:={facade_file}', 'start:=11:00', 'end:=13:00',
                                  'speedup:=60.0', 'panel_processes:=1')
        panel_ids = ['r00c00', 'r00c01', 'r01c00', 'r01c01']
        # the clock is held until the graph is up: by the time the panels track, nothing
        # has timed out waiting for the coordinator
        assert graph.spin_until(lambda: _tracking(latest, panel_ids), 150.0), latest
        timed_out = contract.STATUSES.index(contract.STATUS_TIMED_OUT)
        graph.spin_for(5.0)
        assert all(latest[p]['status'] != timed_out for p in panel_ids), latest
        assert all(latest[p]['setpoint'] > 0.0 for p in panel_ids)  # noon sun: some shade
        os.killpg(launch.pid, signal.SIGINT)  # Ctrl-C in the terminal
        output, _ = launch.communicate(timeout=60)
        survivors = subprocess.run(['pgrep', '-g', str(launch.pid)], capture_output=True,
                                   text=True).stdout.split()
    finally:
        graph.close()
    assert launch.returncode == 0, output
    assert 'the simulated day starts: the graph was ready' in output, output
    assert 'Traceback' not in output and 'process has died' not in output, output
    assert not survivors, output


@pytest.fixture(scope='module')
def panel(ros2_tools):
    """One panel node started with ``ros2 run``, on the wall clock, and a probe beside it."""
    graph = Graph(domain_for(23))
    try:
        process = ros2_tools.start(graph, 'run', PACKAGE, 'panel_node', '--ros-args', '-r',
                                   '__ns:=/facade/r00c00')
        latest = _states(graph)
        assert graph.spin_until(lambda: 'r00c00' in latest, 90.0), graph.stop(process)[1]
        yield graph, latest
        os.killpg(process.pid, signal.SIGINT)
        output, _ = process.communicate(timeout=30)
    finally:
        graph.close()
    assert process.returncode == 0 and 'Traceback' not in output, output


def test_ros2_param_set_refuses_an_out_of_range_value_and_takes_a_good_one(ros2_tools, panel):
    graph, _ = panel
    node = '/facade/r00c00/panel'
    refused = ros2_tools.run(graph, 'param', 'set', '--no-daemon', node, 'setpoint_timeout_s',
                             '-5.0')
    assert 'Setting parameter failed' in refused.stdout + refused.stderr, refused
    kept = ros2_tools.run(graph, 'param', 'get', '--no-daemon', node, 'setpoint_timeout_s')
    assert kept.returncode == 0 and '-5' not in kept.stdout, kept
    taken = ros2_tools.run(graph, 'param', 'set', '--no-daemon', node, 'setpoint_timeout_s',
                           '30.0')
    assert 'Set parameter successful' in taken.stdout, taken
    now = ros2_tools.run(graph, 'param', 'get', '--no-daemon', node, 'setpoint_timeout_s')
    assert '30.0' in now.stdout, now


def test_ros2_topic_pub_setpoints_move_the_panel(ros2_tools, panel):
    graph, latest = panel
    start = float(latest['r00c00']['closure'])
    setpoint = contract.SETPOINT.of('r00c00')
    pub = ros2_tools.start(graph, 'topic', 'pub', '--rate', '1', setpoint.name,
                           setpoint.msgtype, '{data: 0.8}')
    try:
        moved = graph.spin_until(lambda: latest['r00c00']['closure'] > start + 0.3, 90.0)
        tracked = float(latest['r00c00']['setpoint'])
    finally:
        os.killpg(pub.pid, signal.SIGINT)
        pub.communicate(timeout=30)
    assert moved, latest['r00c00']
    assert tracked == pytest.approx(0.8)
    assert np.isfinite(latest['r00c00']['pressure_pa'])
    # and a setpoint out of range is refused by the panel, which keeps 0.8
    bad = publisher(graph.node, contract.SETPOINT.of('r00c00'))
    bad.publish(Float64(data=7.0))
    graph.spin_for(2.0)
    assert float(latest['r00c00']['setpoint']) == pytest.approx(0.8)


def test_ros2_topic_pub_a_facade_setpoints_message_sets_the_panel(ros2_tools, panel):
    graph, latest = panel
    topic = contract.FACADE_SETPOINTS
    pub = ros2_tools.start(graph, 'topic', 'pub', '--rate', '1', topic.name, topic.msgtype,
                           '{name: [r00c01, r00c00], position: [0.9, 0.3]}')
    try:
        taken = graph.spin_until(
            lambda: float(latest['r00c00']['setpoint']) == pytest.approx(0.3), 30.0)
    finally:
        os.killpg(pub.pid, signal.SIGINT)
        pub.communicate(timeout=30)
    assert taken, latest['r00c00']
