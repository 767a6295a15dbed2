"""Supervision of hung children in a real day (``facade`` with two panel processes).

A panel process stopped with SIGSTOP (alive, silent) is killed after ``HUNG_S`` of silence
and restarted, or, stopped before it ever reported, 60 s after its start; the day finishes
with every panel. Apart from ``test_supervision.py`` (the killed ones) so that the two files'
bringup days run side by side under ``--dist loadfile``.
"""

import subprocess
import time

from bringup_day import (assert_one_restart_and_every_panel, begin_day,
                         killed_as_hung_and_restarted, panel_processes_of, start_day)
import pytest
from ros_graph import domain_for, Graph

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
        killed = killed_as_hung_and_restarted(graph, bringup, output, 'silent for 15 s', victim)
        assert killed - stopped >= HUNG_S - 2.0  # its last report came up to 1 s before
    finally:
        graph.close()
    text = output.text
    assert_one_restart_and_every_panel(bringup, text)
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
        killed_as_hung_and_restarted(graph, bringup, output,
                                     'no report 60 s after its start', victim)
    finally:
        graph.close()
    text = output.text
    assert_one_restart_and_every_panel(bringup, text)
