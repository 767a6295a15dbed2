"""The facade bringup as a user runs it: a short day to the summary, and Ctrl-C."""

import signal
import subprocess
import time

import pytest
from ros_graph import domain_for, Graph
from rosbags.rosbag2 import Reader
from rrd_reading import Rrd

CONTROL = 'period_s: 60.0, shading_target: 0.9, min_dwell_s: 300.0, default_closure: 1.0'


@pytest.fixture()
def small_facade_file(small_facade_text, tmp_path):
    path = tmp_path / 'bringup_small.yaml'
    path.write_text(small_facade_text(CONTROL))
    return path


def children_of(path):
    listing = subprocess.run(['pgrep', '-f', str(path)], capture_output=True, text=True)
    return listing.stdout.split()


@pytest.mark.parametrize('processes', [0, 2])
def test_a_short_day_runs_to_the_summary_and_leaves_nothing_running(small_facade_file,
                                                                    processes):
    graph = Graph(domain_for(3 + processes))
    try:
        bringup = graph.start('facade', '--facade', str(small_facade_file), '--start', '11:00',
                              '--end', '11:30', '--speedup', '120', '--panel-processes',
                              str(processes), '--progress-period', '2')
        output, _ = bringup.communicate(timeout=240)
    finally:
        graph.close()
    assert bringup.returncode == 0, output
    assert 'small: day finished at 2026-06-21 11:30 (local)' in output
    assert 'panels reporting: 4/4' in output
    assert 'decisions' in output and 'CPU' in output and 'peak RSS' in output
    assert '| closure' in output  # progress lines
    assert 'Traceback' not in output
    assert not children_of(small_facade_file)


def test_ctrl_c_stops_everything_and_still_summarises(small_facade_file, tmp_path):
    graph = Graph(domain_for(6))
    try:
        bringup = graph.start('facade', '--facade', str(small_facade_file), '--speedup', '60',
                              '--panel-processes', '1', '--progress-period', '1',
                              '--record', '--rerun', 'none', '--out', str(tmp_path / 'out'))
        started = time.monotonic()
        lines = []
        for line in bringup.stdout:
            lines.append(line)
            if '| closure' in line or time.monotonic() - started > 120:
                break
        bringup.send_signal(signal.SIGINT)
        output, _ = bringup.communicate(timeout=60)
    finally:
        graph.close()
    output = ''.join(lines) + output
    assert bringup.returncode == 130, output
    assert 'small: interrupted at' in output
    assert 'Traceback' not in output
    assert not children_of(small_facade_file)
    run = (tmp_path / 'out' / 'latest').resolve()  # the outputs of the part that ran are valid
    with Reader(run / 'bag') as reader:
        assert reader.message_count > 0
    assert any(e.endswith('/mesh') for e in Rrd(run / 'facade.rrd').entities())


@pytest.mark.parametrize('arguments, message', [
    (['--speedup', '0'], '--speedup'), (['--end', '03:00'], '--end'),
    (['--date', '2026-13-01'], '--date'), (['--panel-processes', '9'], '--panel-processes'),
    (['--facade', '/nonexistent/facade.yaml'], 'cannot read'),
    (['--record', '--out', '/proc/flectofold'], 'cannot create')])
def test_bad_options_are_refused_with_a_reason(small_facade_file, arguments, message):
    graph = Graph(domain_for(7))
    try:
        arguments = arguments if '--facade' in arguments else \
            ['--facade', str(small_facade_file), *arguments]
        run = graph.start('facade', *arguments)
        output, _ = run.communicate(timeout=60)
    finally:
        graph.close()
    assert run.returncode == 2 and message in output and 'Traceback' not in output, output
