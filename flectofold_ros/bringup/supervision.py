"""Supervision of the bringup's child processes: death noticed, restart with back-off, record.

Pure (no rclpy): the bringup calls :meth:`Supervisor.check` every quarter second and turns
what it returns into log lines, the progress line, ``/diagnostics`` and the summary.

Policy (``msg_docs/bringup.md``, "Supervision"):

* a child that exits, or is killed, while the bringup has not asked it to stop is **dead**;
  it is noticed at the next check (0.25 s). A child the caller finds hung (alive but silent)
  is killed by :meth:`Supervisor.kill_hung` and then dies the same way;
* it is restarted after a back-off of ``initial_delay_s`` doubling with every consecutive
  death up to ``max_delay_s``; a run of ``stable_s`` or longer counts as healthy, and the next
  death starts the back-off again;
* after ``restart_limit`` consecutive restarts that each died within ``stable_s``, or at once
  when it exits with code 2 (it refused its input: a restart would refuse it again) or 4
  (``NO_ROOM``: a recorder whose disk is full would stop again), the child is **lost**: not
  restarted, its panels lost for good; the bringup then exits non-zero.
"""

from dataclasses import dataclass, field
import os
import signal
import subprocess
import time
from typing import Callable, Optional

from flectofold_ros.runtime.runner import NO_ROOM, PARENT_ENVIRONMENT

#: Exit code of an executable that refused its input (``flectofold_ros.runtime.runner``).
BAD_INPUT = 2


@dataclass(frozen=True)
class RestartPolicy:
    """When a dead child is started again [s of wall time]."""

    initial_delay_s: float = 1.0
    max_delay_s: float = 30.0
    stable_s: float = 60.0
    """A run this long resets the back-off."""
    restart_limit: int = 5
    """Consecutive restarts (each dying within ``stable_s``) before the child is lost."""

    def __post_init__(self):
        if not 0.0 <= self.initial_delay_s <= self.max_delay_s:
            raise ValueError(f'restart delays must satisfy 0 <= initial ({self.initial_delay_s:g}'
                             f' s) <= max ({self.max_delay_s:g} s)')
        if not (isinstance(self.restart_limit, int) and 0 <= self.restart_limit <= 1000):
            raise ValueError(f'restart limit must be a whole number in [0, 1000], got '
                             f'{self.restart_limit!r}')

    def delay_s(self, attempt):
        """Back-off before restart ``attempt`` (1, 2, ...) [s]."""
        return min(self.initial_delay_s * 2.0 ** (attempt - 1), self.max_delay_s)


@dataclass
class Death:
    """One death of a supervised child, and what came of it."""

    name: str
    pid: int
    returncode: int
    at_s: float
    """Monotonic time it was noticed [s]."""
    restart_in_s: Optional[float]
    """Back-off before its restart; None when it is lost."""
    restarted_at_s: Optional[float] = None
    sim_time_s: Optional[float] = None
    """ROS time of the facade when it was noticed, where the caller knows it [s]."""
    hung: str = ''
    """Why the supervisor killed it, when it did: ``silent for 15 s``."""

    @property
    def cause(self):
        """``exit 1``, ``killed by SIGKILL`` or ``hung (silent for 15 s), killed``."""
        if self.hung:
            return f'hung ({self.hung}), killed'
        if self.returncode < 0:
            try:
                return f'killed by {signal.Signals(-self.returncode).name}'
            except ValueError:
                return f'killed by signal {-self.returncode}'
        return f'exit {self.returncode}'


@dataclass
class Child:
    """One supervised process: its command for each start, its panels, its deaths."""

    name: str
    command: Callable[[int], list]
    """Command of start ``n`` (0 the first, 1 the first restart ...)."""
    panels: tuple = ()
    """Panel ids it hosts (none for an observer)."""
    settings_node: str = ''
    """Name of its settings node, under which a panel process reports on /diagnostics."""
    env: Optional[dict] = None
    process: Optional[subprocess.Popen] = None
    starts: int = 0
    started_at_s: float = 0.0
    failures: int = 0
    """Consecutive deaths, each within ``stable_s`` of its start."""
    restart_at_s: Optional[float] = None
    lost: bool = False
    deaths: list = field(default_factory=list)
    hung: str = ''
    """Set by :meth:`Supervisor.kill_hung` until the death is noticed."""

    @property
    def state(self):
        """``running``, ``restarting`` (dead, restart pending) or ``lost``."""
        if self.lost:
            return 'lost'
        return 'restarting' if self.restart_at_s is not None else 'running'

    @property
    def restarts(self):
        return max(self.starts - 1, 0)

    def start(self, now_s):
        # The child asks the kernel to stop it when this process dies, even by SIGKILL
        # (runner.die_with_parent): no orphan of a killed bringup runs on into the next day.
        env = dict(os.environ if self.env is None else self.env,
                   **{PARENT_ENVIRONMENT: str(os.getpid())})
        self.process = subprocess.Popen(self.command(self.starts), env=env)
        self.starts += 1
        self.started_at_s, self.restart_at_s = now_s, None


def hangs(silent_s, reported, running_s, hung_s, start_s):
    """Why a running panel process counts as hung, or '' while it does not [s].

    It hangs when it has been silent on /diagnostics (sent every second) for more than
    ``hung_s``, or, never having ``reported`` anything (no status, no panel state), when it
    has been running for more than ``start_s``: a process that hangs while it starts (stopped,
    deadlocked) would otherwise never count as silent, and its panels, never heard, would hold
    the day's clock for good.
    """
    if silent_s > hung_s:
        return f'silent for {hung_s:g} s'
    if not reported and running_s > start_s:
        return f'no report {start_s:g} s after its start'
    return ''


class Supervisor:
    """Start, watch and restart children; answer what the bringup reports."""

    def __init__(self, policy=RestartPolicy(), clock=time.monotonic):
        self.policy, self.clock = policy, clock
        self.children = []
        self.stopping = False

    def add(self, name, command, panels=(), env=None, settings_node=''):
        """Start a child now; ``command(n)`` is its command line for start ``n``."""
        child = Child(name, command, tuple(panels), settings_node, env)
        child.start(self.clock())
        self.children.append(child)
        return child

    def check(self):
        """Notice deaths and start due restarts; return the events as ``(child, text)``."""
        if self.stopping:
            return []
        now_s, events = self.clock(), []
        for child in self.children:
            if child.state == 'running' and child.process.poll() is not None:
                events.append((child, self._died(child, now_s)))
            elif child.state == 'restarting' and now_s >= child.restart_at_s:
                child.start(now_s)
                child.deaths[-1].restarted_at_s = now_s
                events.append((child, f'{child.name} restarted (pid {child.process.pid}, '
                                      f'restart {child.restarts})'))
        return events

    def _died(self, child, now_s):
        code = child.process.returncode
        child.failures = child.failures + 1 if now_s - child.started_at_s < \
            self.policy.stable_s else 1
        death = Death(child.name, child.process.pid, code, now_s, None, hung=child.hung)
        child.hung = ''
        child.deaths.append(death)
        if code in (BAD_INPUT, NO_ROOM) or child.failures > self.policy.restart_limit:
            child.lost = True
            why = {BAD_INPUT: 'it refused its input',
                   NO_ROOM: 'its disk has no room'}.get(
                code, f'{self.policy.restart_limit} restarts did not keep it up')
            return f'{child.name} (pid {death.pid}) died: {death.cause}; not restarted: {why}'
        death.restart_in_s = self.policy.delay_s(child.failures)
        child.restart_at_s = now_s + death.restart_in_s
        return (f'{child.name} (pid {death.pid}) died: {death.cause}; restart in '
                f'{death.restart_in_s:g} s')

    def kill_hung(self, child, why):
        """Kill a running child found hung (``why``: ``silent for 15 s``).

        The next :meth:`check` notices the death and restarts it as any other.
        """
        if child.state == 'running' and child.process.poll() is None:
            child.hung = why
            child.process.kill()

    # -- questions --------------------------------------------------------------------------

    def ended_while_starting(self):
        """Children that died before the day started (the bringup then gives up)."""
        return [child for child in self.children if child.deaths]

    def panels_down(self):
        """Panel ids of children that are dead now (restart pending or lost)."""
        return [panel for child in self.children if child.state != 'running'
                for panel in child.panels]

    def panels_lost(self):
        """Panel ids lost for good."""
        return [panel for child in self.children if child.lost for panel in child.panels]

    def deaths(self):
        return [death for child in self.children for death in child.deaths]

    def processes(self, panels=None):
        """Return the running ``Popen``: all, or those hosting panels (True) or not (False)."""
        return [child.process for child in self.children if child.state == 'running' and
                (panels is None or bool(child.panels) == panels)]

    # -- the end ----------------------------------------------------------------------------

    def stop(self, timeout_s, panels):
        """SIGTERM the running children with (or without) panels, wait, then SIGKILL."""
        self.stopping = True
        stop_processes(self.processes(panels), timeout_s)

    def summary_lines(self, when=None):
        """One line per death: ``when(death)``, the cause, and the restart or the loss."""
        lines = []
        for child in self.children:
            for death in child.deaths:
                when_text = when(death) if when else f'{death.at_s:.1f} s'
                if death.restarted_at_s is not None:
                    what = f'restarted after {death.restarted_at_s - death.at_s:.1f} s'
                elif death.restart_in_s is not None:
                    what = 'restart pending at the end'
                else:
                    what = 'not restarted: lost'
                lines.append(f'    {child.name} died at {when_text} ({death.cause}), {what}')
        return lines


def stop_processes(processes, timeout_s):
    """SIGTERM every process that still runs (a terminal may have sent SIGINT), then wait.

    SIGTERM, which every executable handles as it does SIGINT, and not SIGINT: a bringup
    started in the background by a shell, or under ``nohup``, hands its children SIGINT
    ignored, and a recorder that never hears the stop is SIGKILLed at the deadline with its
    bag unfinished.
    """
    for process in processes:
        if process.poll() is None:
            process.send_signal(signal.SIGTERM)
    deadline = time.monotonic() + timeout_s
    for process in processes:
        try:
            process.wait(timeout=max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
