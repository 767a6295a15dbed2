"""A test's view of a ROS graph: its own DDS domain, a listening node, child processes."""

import os
from pathlib import Path
import queue
import signal
import subprocess
import sys
import threading
import time

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

BIN = Path(sys.executable).parent
#: Wall seconds within which a process stops, or notices a death, for a test to call it
#: prompt. On an idle machine they take well under 2 s (the figures the docs quote); this
#: leaves room for a machine busy with other work, yet tells a stop that heeds its signal
#: from one that waits out a 10 s escalation or a kill.
PROMPT_S = 8.0
#: Wall seconds within which processes that are starting have their nodes up and talking:
#: imports, the facade's load and the one-facade start check (up to 30 s). Idle they take
#: about 10 s; two CPU burners beside a full suite took the coordinator past 30 s. A safety
#: net against a process that hangs at start, not a time the test judges.
START_S = 120.0


class Graph:
    """Processes and one probe node on one ROS domain; :meth:`close` leaves nothing behind."""

    def __init__(self, domain_id, name='probe'):
        self.domain_id = domain_id
        self.env = dict(os.environ, ROS_DOMAIN_ID=str(domain_id),
                        ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', PYTHONUNBUFFERED='1',
                        RCUTILS_COLORIZED_OUTPUT='0')
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.node = Node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.processes = []

    def start(self, executable, *arguments, group=False, sigint_ignored=False):
        """Start an installed executable of the package on this domain.

        ``group``: as the leader of a new process group, which :meth:`signal_group` reaches
        whole, as a terminal's Ctrl-C does. ``sigint_ignored``: with SIGINT ignored, as a
        shell starts a background job (``&``) and as ``nohup`` does; children inherit it.
        """
        def ignore_sigint():
            signal.signal(signal.SIGINT, signal.SIG_IGN)
        process = subprocess.Popen([str(BIN / executable), *arguments], env=self.env,
                                   stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                   start_new_session=group,
                                   preexec_fn=ignore_sigint if sigint_ignored else None)
        process.flectofold_group = group
        self.processes.append(process)
        return process

    @staticmethod
    def read_until(process, condition, timeout_s):
        """Read ``process``'s output lines until ``condition(line)`` or ``timeout_s``; return them.

        A reader thread keeps the wait bounded: a process that falls silent (or whose children
        keep its output open after it ended) cannot hang the test.
        """
        lines = queue.Queue()

        def read():
            for line in process.stdout:
                lines.put(line)
                if condition(line):
                    break
            lines.put(None)

        threading.Thread(target=read, daemon=True).start()
        deadline, read_lines = time.monotonic() + timeout_s, []
        while (left := deadline - time.monotonic()) > 0:
            try:
                line = lines.get(timeout=left)
            except queue.Empty:
                break
            if line is None:
                break
            read_lines.append(line)
            if condition(line):
                break
        return read_lines

    def spin_until(self, condition, timeout_s):
        """Spin the probe until ``condition()`` holds; return whether it did."""
        deadline = time.monotonic() + timeout_s
        while not condition() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.02)
        return condition()

    def spin_for(self, duration_s):
        self.spin_until(lambda: False, duration_s)

    def stop(self, process, sig=signal.SIGINT, timeout_s=30.0):
        """Signal a process and return its exit code and output.

        The code is None when it had to be killed after ``timeout_s``, a safety net: a test
        of promptness bounds the time itself.
        """
        if process.poll() is None:
            process.send_signal(sig)
        try:
            output, _ = process.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            return None, _kill(process)
        return process.returncode, output

    @staticmethod
    def signal_group(process, sig=signal.SIGINT):
        """Send ``sig`` to every process of ``process``'s group (it must lead one)."""
        os.killpg(process.pid, sig)

    def close(self):
        for process in self.processes:
            if process.poll() is None:
                _kill(process)
            try:
                process.communicate(timeout=10)
            except subprocess.TimeoutExpired:  # orphans of a process that died hold its pipe
                _kill(process)
        self.node.destroy_node()  # before the executor's shutdown, which forgets its nodes
        self.executor.shutdown()
        rclpy.try_shutdown(context=self.context)


def signal_group_and_wait(process, number, timeout_s=30.0):
    """Signal ``process``'s group as a terminal does; return (exit code, output, seconds).

    ``process`` must lead its group (``start_new_session``). Fails the test, after killing
    the group, when it has not stopped within ``timeout_s``.
    """
    import pytest
    started = time.monotonic()
    os.killpg(process.pid, number)
    try:
        output, _ = process.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        output, _ = process.communicate()
        pytest.fail(f'{process.args[0]} did not stop within {timeout_s:g} s of '
                    f'{signal.Signals(number).name}:\n{output}')
    return process.returncode, output, time.monotonic() - started


def _kill(process):
    """SIGKILL ``process`` and every process under it; return what it printed.

    Its children would otherwise live on (orphans keep running and hold its output pipe
    open, so reading that pipe to its end would never return).
    """
    for pid in [*_descendants(process.pid), process.pid]:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    if process.flectofold_group:
        try:
            os.killpg(process.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    try:
        output, _ = process.communicate(timeout=10)
    except subprocess.TimeoutExpired:  # an orphan it left before this call holds the pipe
        output = ''
    return output


def _descendants(pid):
    listing = subprocess.run(['pgrep', '-P', str(pid)], capture_output=True, text=True)
    children = [int(child) for child in listing.stdout.split()]
    return [grandchild for child in children for grandchild in _descendants(child)] + children


def domain_for(offset):
    """Pick a ROS domain for this test process: parallel runs on one host stay apart.

    Under pytest-xdist each of up to four workers has its own 20 domains (10-29, 30-49, 50-69,
    70-89), so that two tests running at once never share one.
    """
    worker = int(os.environ.get('PYTEST_XDIST_WORKER', 'gw0')[2:]) % 4
    return 10 + 20 * worker + (os.getpid() + offset) % 20


def bench_domains():
    """Pick the first of two ROS domains for a benchmark a test runs (it takes the next too).

    90-97, two per pytest-xdist worker: outside the 10-89 of :func:`domain_for`, so that a
    benchmark's facade never shares a domain with another test's (the graph benchmark's
    default, 60 and 61, lay inside the third worker's range: its 36 panels and clock mixed
    into the tests there).
    """
    worker = int(os.environ.get('PYTEST_XDIST_WORKER', 'gw0')[2:]) % 4
    return 90 + 2 * worker


def on_facade_setpoints(node, callback):
    """Subscribe ``node`` to ``/facade/setpoints``; ``callback(panel_id, closure)`` per entry."""
    from flectofold_ros.wire import contract
    from flectofold_ros.runtime.interfaces import subscription

    def each_entry(message):
        for name, closure in zip(message.name, message.position):
            callback(name, closure)

    return subscription(node, contract.FACADE_SETPOINTS, each_entry)
