"""Supervision policy (flectofold_ros.bringup.supervision) with real short-lived processes.

Deaths are noticed, restarted after a doubling back-off capped at its maximum, a stable run
resets the back-off, a child that refused its input or kept dying is lost; children asked to
stop are not deaths.
"""

import signal
import subprocess
import sys

import pytest

from flectofold_ros.bringup.supervision import Death, hangs, RestartPolicy, Supervisor
from flectofold_ros.runtime.runner import NO_ROOM


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


def test_a_recorder_whose_disk_has_no_room_is_not_restarted_onto_it():
    # Before, it was restarted onto the same full disk, and the rest of the day (2.3 h) went
    # unrecorded with only a restart in the summary.
    clock = FakeClock()
    supervisor = Supervisor(clock=clock)
    child = supervisor.add('bag_recorder', exiting(NO_ROOM))
    (event,) = settle(supervisor, clock, 0.1)
    assert event.endswith('died: exit 4; not restarted: its disk has no room') and child.lost
    assert child.starts == 1 and supervisor.summary_lines()[0].endswith(
        '(exit 4), not restarted: lost')


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


def test_restart_limit_is_checked():
    run = subprocess.run([sys.executable, '-m', 'flectofold_ros', 'facade', '--restart-limit',
                          '-1'], capture_output=True, text=True, timeout=60)
    assert run.returncode == 2 and '--restart-limit must lie in [0, 1000]' in run.stderr


def test_signal_names_in_causes():
    assert Death('x', 1, -signal.SIGKILL, 0.0, None).cause == 'killed by SIGKILL'
    assert Death('x', 1, 1, 0.0, None).cause == 'exit 1'


def test_a_process_silent_past_the_bound_hangs_and_at_the_bound_does_not():
    assert hangs(15.0, True, 100.0, 15.0, 60.0) == ''
    assert hangs(15.001, True, 100.0, 15.0, 60.0) == 'silent for 15 s'


def test_a_process_that_never_reported_hangs_once_it_has_run_past_the_start_wait():
    # Stopped before its first report, it is never silent (silent_s 0) and its panels,
    # never heard, would hold the clock for good.
    assert hangs(0.0, False, 60.0, 15.0, 60.0) == ''
    assert hangs(0.0, False, 60.001, 15.0, 60.0) == 'no report 60 s after its start'


def test_a_process_that_reported_is_judged_by_its_silence_only():
    assert hangs(1.0, True, 3600.0, 15.0, 60.0) == ''
