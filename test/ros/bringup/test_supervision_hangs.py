"""Supervision of hung children in a real day (``facade`` with two panel processes).

A panel process stopped with SIGSTOP (alive, silent) is killed after ``HUNG_S`` of silence
and restarted, or, stopped before it ever reported, 60 s after its start; the day finishes
with every panel. Apart from ``test_supervision.py`` (the killed ones) so that the two files'
bringup days run side by side under ``--dist loadfile``.
"""

import subprocess
import time

from bringup_day import begin_day, end_day, panel_processes_of, start_day
import pytest
from ros_graph import domain_for, Graph, START_S

from flectofold_ros.bringup.cli import HUNG_S

pytestmark = pytest.mark.graph


def test_a_hung_panel_process_is_killed_and_restarted(small_facade_file):
    """SIGSTOP: alive but silent. Its /diagnostics stop; after 15 s it is killed, restarted."""
    graph = Graph(domain_for(56))
    try:
        bringup, output = start_day(graph, small_facade_file, '11:40', '--panel-processes', '2')
        victim = panel_processes_of(bringup.pid)[0]
        subprocess.run(['kill', '-STOP', str(victim)], check=True)
        stopped = time.monotonic()
        hung = output.wait_for(graph, 'hung (silent for 15 s), killed', 60)
        assert hung and f'(pid {victim})' in hung, output.text
        assert time.monotonic() - stopped >= HUNG_S - 2.0  # its last report came up to 1 s before
        assert output.wait_for(graph, 'restarted (pid', START_S), output.text
        end_day(graph, bringup, output, 60)
    finally:
        graph.close()
    text = output.text
    assert bringup.returncode == 0, text
    assert 'panels reporting: 4/4' in text and '1 deaths, 1 restarts' in text, text
    assert 'panel_group 0/2 died at 11:' in text and 'hung (silent for 15 s), killed' in text


def test_a_panel_process_that_hangs_before_its_first_report_is_killed_and_restarted(
        small_facade_file):
    """SIGSTOP at its start: never silent, as it never spoke; 60 s after its start it is hung."""
    graph = Graph(domain_for(57))
    try:
        bringup, output = begin_day(graph, small_facade_file, '11:20', '--panel-processes', '2')
        assert graph.spin_until(lambda: panel_processes_of(bringup.pid), 60.0), output.text
        victim = panel_processes_of(bringup.pid)[0]
        subprocess.run(['kill', '-STOP', str(victim)], check=True)
        assert output.wait_for(graph, 'starting the day anyway', 120), output.text
        hung = output.wait_for(graph, 'hung (no report 60 s after its start), killed', 60)
        assert hung and f'(pid {victim})' in hung, output.text
        assert output.wait_for(graph, 'restarted (pid', START_S), output.text
        end_day(graph, bringup, output, 60)
    finally:
        graph.close()
    text = output.text
    assert bringup.returncode == 0, text
    assert 'panels reporting: 4/4' in text and '1 deaths, 1 restarts' in text, text
