"""A test's view of a ROS graph: its own DDS domain, a listening node, child processes."""

import os
from pathlib import Path
import signal
import subprocess
import sys
import time

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

BIN = Path(sys.executable).parent


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

    def start(self, executable, *arguments, group=False):
        """Start an installed executable of the package on this domain.

        ``group``: as the leader of a new process group, which :meth:`signal_group` reaches
        whole, as a terminal's Ctrl-C does.
        """
        process = subprocess.Popen([str(BIN / executable), *arguments], env=self.env,
                                   stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                   start_new_session=group)
        self.processes.append(process)
        return process

    def spin_until(self, condition, timeout_s):
        """Spin the probe until ``condition()`` holds; return whether it did."""
        deadline = time.monotonic() + timeout_s
        while not condition() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.02)
        return condition()

    def spin_for(self, duration_s):
        self.spin_until(lambda: False, duration_s)

    def stop(self, process, sig=signal.SIGINT, timeout_s=10.0):
        """Signal a process and return its exit code and output."""
        if process.poll() is None:
            process.send_signal(sig)
        try:
            output, _ = process.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            process.kill()
            output, _ = process.communicate()
            return None, output
        return process.returncode, output

    @staticmethod
    def signal_group(process, sig=signal.SIGINT):
        """Send ``sig`` to every process of ``process``'s group (it must lead one)."""
        os.killpg(process.pid, sig)

    def close(self):
        for process in self.processes:
            if process.poll() is None:
                process.kill()
            process.communicate()
        self.node.destroy_node()  # before the executor's shutdown, which forgets its nodes
        self.executor.shutdown()
        rclpy.try_shutdown(context=self.context)


def domain_for(offset):
    """Pick a ROS domain for this test process: parallel runs on one host stay apart."""
    return (os.getpid() + offset) % 40 + 10
