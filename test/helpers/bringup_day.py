"""A ``facade`` bringup day for the supervision tests: a small facade, its output on a thread."""

import queue
import subprocess
import threading
import time

from ros_graph import START_S

CONTROL = 'period_s: 60.0, shading_target: 0.9, min_dwell_s: 300.0, default_closure: 1.0'


def supervised_facade_file(small_facade_text, tmp_path):
    """Write the small facade the supervision days run; return its path."""
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
        self._reader = threading.Thread(target=self._read, args=(process,), daemon=True)
        self._reader.start()

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

    def rest(self, graph, timeout_s=30.0):
        """Once the process has ended, take its output to the end (every holder closed it)."""
        graph.spin_until(lambda: not self._reader.is_alive(), timeout_s)
        while not self._queue.empty():
            self.lines.append(self._queue.get())

    @property
    def text(self):
        return ''.join(self.lines)


def begin_day(graph, facade_file, end, *options):
    """Start ``facade`` from 11:00 to ``end`` at 120x; return it and its output at once."""
    bringup = graph.start('facade', '--facade', str(facade_file), '--start', '11:00', '--end',
                          end, '--speedup', '120', '--progress-period', '1', *options)
    return bringup, Lines(bringup)


def start_day(graph, facade_file, end, *options):
    """Start ``facade`` as :func:`begin_day`; return it and its output once all report."""
    bringup, output = begin_day(graph, facade_file, end, *options)
    assert output.wait_for(graph, '| panels reporting 4/4', 180), output.text
    return bringup, output


def end_day(graph, bringup, output, exit_timeout_s):
    """Wait for the day to finish, the bringup to exit and the rest of its output."""
    assert output.wait_for(graph, 'day finished', 240), output.text
    bringup.wait(timeout=exit_timeout_s)
    output.rest(graph)


def killed_as_hung_and_restarted(graph, bringup, output, reason, victim):
    """Wait for ``facade`` to kill ``victim`` as hung for ``reason``, restart it, end the day.

    Return the monotonic time the kill was read.
    """
    hung = output.wait_for(graph, f'hung ({reason}), killed', 60)
    read = time.monotonic()
    assert hung and f'(pid {victim})' in hung, output.text
    assert output.wait_for(graph, 'restarted (pid', START_S), output.text
    end_day(graph, bringup, output, 60)
    return read


def assert_one_restart_and_every_panel(bringup, text):
    """Assert the day ended well with its 4 panels, one panel process dead and restarted."""
    assert bringup.returncode == 0, text
    assert 'panels reporting: 4/4' in text and '1 deaths, 1 restarts' in text, text


def finish(graph, process, timeout_s):
    """Wait (spinning the probe) for ``process`` to end; return its exit code."""
    graph.spin_until(lambda: process.poll() is not None, timeout_s)
    return process.poll()
