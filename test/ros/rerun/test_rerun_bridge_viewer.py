"""The rerun_bridge asked to spawn a viewer that cannot be, or that goes: the .rrd goes on.

Each bridge runs as the leader of its own process group with SIGINT at its default (as a
terminal's foreground job) and is stopped by a signal to the whole group.
"""

import os
from pathlib import Path
import signal
import subprocess
import time

import pytest
from ros_graph import BIN, domain_for, Graph, PROMPT_S, signal_group_and_wait
from rrd_reading import Rrd

pytestmark = pytest.mark.graph
#: Entities the bridge logs statically at its start: in every .rrd it finishes.
STATIC = {'/facade/surface', '/facade/panel_frames', '/facade/panels'}


def foreground():
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def environment(tmp_path, display=None, python_path=None):
    env = {k: v for k, v in os.environ.items() if k not in ('DISPLAY', 'WAYLAND_DISPLAY')}
    env.update(ROS_DOMAIN_ID=str(domain_for(48)), PYTHONUNBUFFERED='1',
               RCUTILS_COLORIZED_OUTPUT='0', ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    if display is not None:
        env['DISPLAY'] = display
    if python_path is not None:
        env['PYTHONPATH'] = f'{python_path}{os.pathsep}{env.get("PYTHONPATH", "")}'
    return env


def start_bridge(tmp_path, env, *parameters):
    command = [str(BIN / 'rerun_bridge'), '--ros-args', '-p', 'viewer:=spawn',
               '-p', 'viewer_port:=19876', *parameters]
    return subprocess.Popen(command, cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True,
                            preexec_fn=foreground)


def wait_for(bridge, *texts, timeout_s=60.0):
    """Read the bridge's output until every one of ``texts`` was in a line; return the lines."""
    missing = set(texts)

    def seen_all(line):
        missing.difference_update({text for text in missing if text in line})
        return not missing

    lines = Graph.read_until(bridge, seen_all, timeout_s)
    assert not missing, ''.join(lines)
    return lines


def stop(bridge, number):
    """Signal the group; return (exit code, the rest of the output, seconds to the exit)."""
    return signal_group_and_wait(bridge, number)


def assert_clean_stop(bridge, number, rrd_path, before):
    code, output, took_s = stop(bridge, number)
    everything = ''.join(before) + output
    assert code == 0 and took_s < PROMPT_S, (code, took_s, everything)
    for word in ('Traceback', 'FATAL', 'KeyboardInterrupt'):
        assert word not in everything, everything
    assert STATIC <= Rrd(rrd_path).entities()
    return everything


@pytest.mark.parametrize('number', [signal.SIGINT, signal.SIGTERM])
def test_spawn_without_a_display_saves_the_rrd_and_stops_on_a_signal(tmp_path, number):
    bridge = start_bridge(tmp_path, environment(tmp_path))
    lines = wait_for(bridge, 'without a display', 'logging 36 panels to')
    time.sleep(1.5)  # running: a few flushes and a diagnostics round
    (rrd_path,) = tmp_path.glob('flectofold_*.rrd')
    assert_clean_stop(bridge, number, rrd_path, lines)


def test_a_viewer_that_cannot_open_its_window_leaves_the_rrd(tmp_path):
    rrd_path = tmp_path / 'day.rrd'
    bridge = start_bridge(tmp_path, environment(tmp_path, display=':99'),
                          '-p', f'rrd_path:={rrd_path}')
    lines = wait_for(bridge, 'the Rerun viewer exited', 'logging 36 panels to')
    assert_clean_stop(bridge, signal.SIGINT, rrd_path, lines)


def fake_viewer(tmp_path, script):
    """Write a ``rerun_cli`` package whose viewer binary runs ``script`` (None: no binary)."""
    package = tmp_path / 'fake' / 'rerun_cli'
    package.mkdir(parents=True)
    (package / '__init__.py').write_text('')
    if script is not None:
        binary = package / 'rerun'
        binary.write_text(f'#!/bin/sh\n{script}\n')
        binary.chmod(0o755)
    return package.parent


def test_a_missing_viewer_binary_leaves_the_rrd(tmp_path):
    rrd_path = tmp_path / 'day.rrd'
    env = environment(tmp_path, display=':99', python_path=fake_viewer(tmp_path, None))
    bridge = start_bridge(tmp_path, env, '-p', f'rrd_path:={rrd_path}')
    lines = wait_for(bridge, 'cannot start the Rerun viewer', 'logging 36 panels to')
    assert_clean_stop(bridge, signal.SIGTERM, rrd_path, lines)


def test_a_viewer_killed_while_the_bridge_runs_leaves_the_rrd(tmp_path):
    rrd_path, pid_file = tmp_path / 'day.rrd', tmp_path / 'viewer.pid'
    env = environment(tmp_path, display=':99', python_path=fake_viewer(
        tmp_path, f'echo $$ > {pid_file}\nexec sleep 120'))
    bridge = start_bridge(tmp_path, env, '-p', f'rrd_path:={rrd_path}')
    try:
        lines = wait_for(bridge, 'logging 36 panels to')
        viewer_pid = int(Path(pid_file).read_text())
        os.kill(viewer_pid, signal.SIGKILL)
        lines += wait_for(bridge, 'the Rerun viewer exited (exit -9)', timeout_s=10.0)
    finally:
        if pid_file.exists():
            subprocess.run(['kill', '-9', pid_file.read_text().strip()], capture_output=True)
    assert_clean_stop(bridge, signal.SIGINT, rrd_path, lines)
