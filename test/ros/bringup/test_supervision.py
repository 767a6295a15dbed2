"""Supervision of the bringup's children: the policy with real short processes, then the day.

A panel process killed with SIGKILL during the day is noticed, logged, reported on
``/diagnostics``, restarted after its back-off; its panels report again and track; the
summary lists the death and the restart. With no restarts allowed the panels are lost for
good and the bringup exits 3.
"""

import queue
import signal
import subprocess
import sys
import threading
import time

import pytest
from ros_graph import domain_for, Graph

from flectofold_ros import contract
from flectofold_ros.bringup.supervision import RestartPolicy, Supervisor
from flectofold_ros.interfaces import message_class


class FakeClock:
    def __init__(self):
        self.now_s = 0.0

    def __call__(self):
        return self.now_s


def exiting(code, after_s=0.0):
    """Command of a child that exits with ``code`` after ``after_s``."""
    return lambda start: [sys.executable, '-c',
                          f'import sys, time; time.sleep({after_s}); sys.exit({code})']


def settle(supervisor, clock, step_s):
    """Let every child's process end, advance the clock, check; return the event texts."""
    for child in supervisor.children:
        if child.state == 'running':
            child.process.wait(timeout=10)
    clock.now_s += step_s
    return [text for _, text in supervisor.check()]


def test_a_death_is_noticed_and_restarted_after_a_doubling_back_off():
    clock = FakeClock()
    supervisor = Supervisor(RestartPolicy(initial_delay_s=1.0, max_delay_s=3.0,
                                          restart_limit=3), clock)
    child = supervisor.add('panel_group 0/1', exiting(1), panels=['a', 'b'])
    events = settle(supervisor, clock, 0.1)
    assert events == [f'panel_group 0/1 (pid {child.deaths[0].pid}) died: exit 1; restart in '
                      f'1 s']
    assert child.state == 'restarting' and supervisor.panels_down() == ['a', 'b']
    assert supervisor.check() == []  # not before its back-off
    clock.now_s += 1.0
    assert [text for _, text in supervisor.check()][0].endswith('restart 1)')
    delays, events = [], []
    for _ in range(3):
        events = settle(supervisor, clock, 0.1)
        if child.lost:
            break
        delays.append(child.deaths[-1].restart_in_s)
        clock.now_s += delays[-1]
        supervisor.check()
    assert delays == [2.0, 3.0]  # doubled, then capped at max_delay_s
    assert child.lost and supervisor.panels_lost() == ['a', 'b']
    assert events[0].endswith('not restarted: 3 restarts did not keep it up')
    lines = supervisor.summary_lines()
    assert len(lines) == 4 and lines[0].endswith('(exit 1), restarted after 1.0 s')
    assert lines[-1].endswith('(exit 1), not restarted: lost')


def test_a_stable_run_resets_the_back_off():
    clock = FakeClock()
    supervisor = Supervisor(RestartPolicy(initial_delay_s=1.0, stable_s=60.0), clock)
    child = supervisor.add('bag_recorder', exiting(1))
    settle(supervisor, clock, 0.1)
    clock.now_s += 1.0
    supervisor.check()
    settle(supervisor, clock, 0.1)
    assert child.deaths[-1].restart_in_s == 2.0
    clock.now_s += 2.0
    supervisor.check()
    settle(supervisor, clock, 61.0)  # this run lasted over stable_s
    assert child.deaths[-1].restart_in_s == 1.0


def test_a_child_that_refused_its_input_is_not_restarted():
    clock = FakeClock()
    supervisor = Supervisor(clock=clock)
    child = supervisor.add('panel_group 0/2', exiting(2), panels=['a'])
    (event,) = settle(supervisor, clock, 0.1)
    assert 'not restarted: it refused its input' in event and child.lost


def test_children_asked_to_stop_are_not_deaths():
    supervisor = Supervisor()
    child = supervisor.add('panel_group 0/1', exiting(0, after_s=30.0), panels=['a'])
    supervisor.stop(5.0, panels=True)
    assert child.process.returncode is not None
    assert supervisor.check() == [] and supervisor.deaths() == []


def test_bad_policies_are_refused():
    with pytest.raises(ValueError, match='restart limit'):
        RestartPolicy(restart_limit=-1)
    with pytest.raises(ValueError, match='restart delays'):
        RestartPolicy(initial_delay_s=40.0, max_delay_s=30.0)


# -- the bringup, with real processes -----------------------------------------------------

CONTROL = 'period_s: 60.0, shading_target: 0.9, min_dwell_s: 300.0, default_closure: 1.0'


@pytest.fixture()
def small_facade_file(small_facade_text, tmp_path):
    path = tmp_path / 'supervised_small.yaml'
    path.write_text(small_facade_text(CONTROL))
    return path


def panel_processes_of(pid):
    listing = subprocess.run(['pgrep', '-P', str(pid), '-f', 'panel_group'],
                             capture_output=True, text=True)
    return [int(child) for child in listing.stdout.split()]


class Lines:
    """The output of a process, read on a thread; waited on while the probe spins."""

    def __init__(self, process):
        self.lines, self._queue = [], queue.Queue()
        threading.Thread(target=self._read, args=(process,), daemon=True).start()

    def _read(self, process):
        for line in process.stdout:
            self._queue.put(line)

    def wait_for(self, graph, text, timeout_s):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            graph.executor.spin_once(timeout_sec=0.05)
            while not self._queue.empty():
                self.lines.append(self._queue.get())
                if text in self.lines[-1]:
                    return self.lines[-1]
        return None

    @property
    def text(self):
        return ''.join(self.lines)


@pytest.mark.graph
def test_a_killed_panel_process_is_restarted_and_its_panels_track_again(small_facade_file):
    graph = Graph(domain_for(51))
    supervision = []
    graph.node.create_subscription(
        message_class(contract.DIAGNOSTICS.msgtype), contract.DIAGNOSTICS.name,
        lambda message: supervision.extend(
            (status.hardware_id, ord(status.level), status.message) for status in message.status
            if status.name.endswith(': supervision')), 50)
    try:
        bringup = graph.start('facade', '--facade', str(small_facade_file), '--start', '11:00',
                              '--end', '11:40', '--speedup', '120', '--panel-processes', '2',
                              '--progress-period', '1')
        output = Lines(bringup)
        assert output.wait_for(graph, '| panels reporting 4/4', 180), output.text
        victim = panel_processes_of(bringup.pid)[-1]
        signal_sent = time.monotonic()
        subprocess.run(['kill', '-KILL', str(victim)], check=True)
        died = output.wait_for(graph, 'died: killed by SIGKILL', 30)
        assert died and f'(pid {victim})' in died, output.text
        assert time.monotonic() - signal_sent < 5.0  # noticed within a few seconds
        assert output.wait_for(graph, 'restarted (pid', 30), output.text
        assert output.wait_for(graph, 'panels reporting 2/4', 30), output.text
        assert output.wait_for(graph, 'day finished', 240), output.text
        bringup.wait(timeout=60)
        output.wait_for(graph, 'never printed', 2.0)
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


@pytest.mark.graph
def test_panels_lost_for_good_end_the_day_with_exit_code_3(small_facade_file):
    graph = Graph(domain_for(52))
    try:
        bringup = graph.start('facade', '--facade', str(small_facade_file), '--start', '11:00',
                              '--end', '11:30', '--speedup', '120', '--panel-processes', '2',
                              '--progress-period', '1', '--restart-limit', '0')
        output = Lines(bringup)
        assert output.wait_for(graph, '| panels reporting 4/4', 180), output.text
        subprocess.run(['kill', '-KILL', str(panel_processes_of(bringup.pid)[0])], check=True)
        assert output.wait_for(graph, 'not restarted', 30), output.text
        assert output.wait_for(graph, '(2 lost)', 30), output.text
        bringup.wait(timeout=240)
        output.wait_for(graph, 'never printed', 2.0)
    finally:
        graph.close()
    text = output.text
    assert bringup.returncode == 3, text
    assert 'day finished' in text and 'panels reporting: 2/4' in text
    assert '1 deaths, 0 restarts, 2 panels lost for good (r00c00, r00c01)' in text, text
    assert 'not restarted: lost' in text


def test_restart_limit_is_checked(small_facade_file):
    run = subprocess.run([sys.executable, '-m', 'flectofold_ros', 'facade', '--restart-limit',
                          '-1'], capture_output=True, text=True, timeout=60)
    assert run.returncode == 2 and '--restart-limit must lie in [0, 1000]' in run.stderr


def test_signal_names_in_causes():
    from flectofold_ros.bringup.supervision import Death
    assert Death('x', 1, -signal.SIGKILL, 0.0, None).cause == 'killed by SIGKILL'
    assert Death('x', 1, 1, 0.0, None).cause == 'exit 1'
