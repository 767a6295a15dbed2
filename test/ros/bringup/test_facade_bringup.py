"""The facade bringup as a user runs it: a short day to the summary, and Ctrl-C."""

from pathlib import Path
import signal
import subprocess
import time

import pytest
from ros_graph import domain_for, Graph
from rosbags.rosbag2 import Reader
from rrd_reading import Rrd
import yaml

pytestmark = pytest.mark.graph
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


def bag_is_complete(bag):
    """Check that the metadata lists every segment and the segments hold what it counts."""
    metadata = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert metadata['relative_file_paths'], metadata
    assert not list((bag / '.open_segment').glob('*.mcap'))  # no data stranded
    with Reader(bag) as reader:
        assert reader.message_count == metadata['message_count'] > 0
        counted = sum(1 for _ in reader.messages())
    assert counted == metadata['message_count']


@pytest.mark.parametrize('signals', [(signal.SIGINT, signal.SIGINT), (signal.SIGTERM,)],
                         ids=['ctrl-c twice', 'service manager sigterm'])
def test_a_signal_to_the_whole_group_stops_everything_and_keeps_the_outputs(
        small_facade_file, tmp_path, signals):
    graph = Graph(domain_for(6))
    try:
        bringup = graph.start('facade', '--facade', str(small_facade_file), '--speedup', '60',
                              '--panel-processes', '1', '--progress-period', '1',
                              '--record', '--rerun', 'none', '--out', str(tmp_path / 'out'),
                              group=True)
        lines = graph.read_until(bringup, lambda line: '| closure' in line, 120.0)
        for sig in signals:  # as a terminal sends it: to the bringup and all its children
            graph.signal_group(bringup, sig)
            time.sleep(0.3)
        output, _ = bringup.communicate(timeout=180)
    finally:
        graph.close()
    output = ''.join(lines) + output
    assert bringup.returncode == 130, output
    assert 'small: interrupted at' in output
    for word in ('Traceback', 'FATAL', 'KeyboardInterrupt'):
        assert word not in output, output
    assert not children_of(small_facade_file)
    run = (tmp_path / 'out' / 'latest').resolve()  # the outputs of the part that ran are whole
    bag_is_complete(run / 'bag')
    assert '/facade/panels' in Rrd(run / 'facade.rrd').entities()


def test_ctrl_c_to_the_bringup_alone_stops_its_children_too(small_facade_file, tmp_path):
    graph = Graph(domain_for(8))
    try:
        bringup = graph.start('facade', '--facade', str(small_facade_file), '--speedup', '60',
                              '--panel-processes', '1', '--progress-period', '1', '--record',
                              '--out', str(tmp_path / 'out'))
        lines = graph.read_until(bringup, lambda line: '| closure' in line, 120.0)
        bringup.send_signal(signal.SIGINT)
        output, _ = bringup.communicate(timeout=180)
    finally:
        graph.close()
    output = ''.join(lines) + output
    assert bringup.returncode == 130 and 'Traceback' not in output, output
    assert not children_of(small_facade_file)
    bag_is_complete((tmp_path / 'out' / 'latest').resolve() / 'bag')


def test_started_in_the_background_with_sigint_ignored_its_day_ends_with_whole_outputs(
        small_facade_file, tmp_path):
    """A shell's ``&`` and ``nohup`` start the bringup, and so its children, with SIGINT ignored.

    At the end of the day the bringup stops its recorder with SIGTERM, which still reaches it:
    the bag is finished, not killed at the deadline.
    """
    graph = Graph(domain_for(9))
    try:
        bringup = graph.start('facade', '--facade', str(small_facade_file), '--start', '11:00',
                              '--end', '11:10', '--speedup', '120', '--panel-processes', '1',
                              '--record', '--rerun', 'none', '--out', str(tmp_path / 'out'),
                              sigint_ignored=True)
        output, _ = bringup.communicate(timeout=240)
    finally:
        graph.close()
    assert bringup.returncode == 0 and 'Traceback' not in output, output
    assert ': complete,' in output and 'INCOMPLETE' not in output, output
    assert not children_of(small_facade_file)
    bag_is_complete((tmp_path / 'out' / 'latest').resolve() / 'bag')


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


def test_the_obj_example_from_cad_runs_through_a_day():
    """A surface from CAD (examples/: an OBJ quad mesh, one quad per panel) drives a day."""
    example = Path(__file__).resolve().parents[3] / 'examples' / 'obj_cylinder_4x3.yaml'
    graph = Graph(domain_for(28))
    try:
        bringup = graph.start('facade', '--facade', str(example), '--start', '13:00',
                              '--end', '13:20', '--speedup', '120', '--panel-processes', '1')
        output, _ = bringup.communicate(timeout=240)
    finally:
        graph.close()
    assert bringup.returncode == 0 and 'Traceback' not in output, output
    assert 'panels reporting: 12/12' in output, output
    assert 'panels in setpoint timeout 0' in output, output
