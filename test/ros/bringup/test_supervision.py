"""Supervision of the bringup's children in a real day (``facade`` with two panel processes).

A panel process killed with SIGKILL during the day is noticed, logged, reported on
``/diagnostics``, restarted after its back-off; its panels report again and track; the
summary lists the death and the restart. With no restarts allowed the panels are lost for
good and the bringup exits 3. Hung panel processes: `test_supervision_hangs.py`.
"""

import subprocess
import time

from bringup_day import end_day, panel_processes_of, start_day
import pytest
from ros_graph import domain_for, Graph, PROMPT_S, START_S

from flectofold_ros.runtime.interfaces import subscription
from flectofold_ros.wire import contract

pytestmark = pytest.mark.graph


def test_a_killed_panel_process_is_restarted_and_its_panels_track_again(small_facade_file):
    graph = Graph(domain_for(51))
    supervision = []
    subscription(graph.node, contract.DIAGNOSTICS, lambda message: supervision.extend(
        (status.hardware_id, ord(status.level), status.message) for status in message.status
        if status.name.endswith(': supervision')))
    try:
        bringup, output = start_day(graph, small_facade_file, '11:40', '--panel-processes', '2')
        victim = panel_processes_of(bringup.pid)[-1]
        signal_sent = time.monotonic()
        subprocess.run(['kill', '-KILL', str(victim)], check=True)
        died = output.wait_for(graph, 'died: killed by SIGKILL', 30)
        assert died and f'(pid {victim})' in died, output.text
        assert time.monotonic() - signal_sent < PROMPT_S  # noticed at once, not at a timeout
        assert output.wait_for(graph, 'restarted (pid', START_S), output.text
        assert output.wait_for(graph, 'panels reporting 2/4', 30), output.text
        end_day(graph, bringup, output, 60)
    finally:
        graph.close()
    text = output.text
    assert bringup.returncode == 0, text
    assert 'panels reporting: 4/4' in text
    assert 'supervision: 1 deaths, 1 restarts, 0 panels lost for good' in text
    assert 'panel_group 1/2 died at 11:' in text and 'restarted after' in text
    error = float(text.split('final |closure - setpoint| max ')[1].split()[0])
    assert error < 0.05, text  # the restarted panels track their setpoints again
    levels = [level for name, level, _ in supervision if name == 'panel_group 1/2']
    assert 1 in levels and levels[-1] == 0, supervision  # WARN while restarting, then OK
    assert 'Traceback' not in text


def test_panels_lost_for_good_end_the_day_with_exit_code_3(small_facade_file, tmp_path):
    """Also a fault script: the other process's panel loses its supply at 11:05."""
    faults = tmp_path / 'faults.yaml'
    faults.write_text("- {at: '11:05', panels: [r01c01], fault: supply_loss}\n")
    graph = Graph(domain_for(52))
    try:
        bringup, output = start_day(graph, small_facade_file, '11:30', '--panel-processes', '2',
                                    '--restart-limit', '0', '--faults', str(faults))
        subprocess.run(['kill', '-KILL', str(panel_processes_of(bringup.pid)[0])], check=True)
        assert output.wait_for(graph, 'not restarted', 30), output.text
        assert output.wait_for(graph, '(2 lost)', 30), output.text
        bringup.wait(timeout=240)
        output.rest(graph)
    finally:
        graph.close()
    text = output.text
    assert bringup.returncode == 3, text
    assert 'day finished' in text and 'panels reporting: 2/4' in text
    assert '1 deaths, 0 restarts, 2 panels lost for good (r00c00, r00c01)' in text, text
    assert 'not restarted: lost' in text
    assert 'faults: supply_lost' in text  # the scripted fault, found by the panel's loop


def test_a_killed_recorder_is_restarted_into_a_new_bag_and_the_summary_says_so(
        small_facade_file, tmp_path):
    graph = Graph(domain_for(55))
    try:
        bringup, output = start_day(graph, small_facade_file, '11:40', '--panel-processes', '1',
                                    '--record', '--out', str(tmp_path / 'out'))
        graph.spin_for(3.0)  # the recorder writes a few seconds of the day
        listing = subprocess.run(['pgrep', '-P', str(bringup.pid), '-f', 'bag_recorder'],
                                 capture_output=True, text=True).stdout.split()
        subprocess.run(['kill', '-KILL', listing[0]], check=True)
        assert output.wait_for(graph, 'bag_recorder (pid', START_S), output.text
        end_day(graph, bringup, output, 120)
    finally:
        graph.close()
    text = output.text
    assert bringup.returncode == 0, text
    assert 'bag_recorder died at 11:' in text and 'restarted after' in text, text
    run = next((tmp_path / 'out').glob('2026-*'))
    assert (run / 'bag.restart1' / 'metadata.yaml').exists()
    assert f'bag {run / "bag"}: INCOMPLETE' in text and 'bag_reindex' in text, text
    assert f'bag {run / "bag.restart1"}: complete' in text, text
