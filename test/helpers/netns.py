"""Test hosts in network namespaces: the ``ip`` command, waiting for a link, processes inside.

Shared by the multi-host, site-network and BACnet broadcast tests, which make their own
namespaces (root and ``ip netns`` needed) and remove them.
"""

import json
import os
from pathlib import Path
import shutil
import signal
import subprocess
import threading
import time

ROOT = Path(__file__).resolve().parents[2]
#: Run inside a namespace: wait until interface argv[1] has IFF_RUNNING (0x40), the flag
#: getifaddrs() reports, read with SIOCGIFFLAGS (0x8913); give up after argv[2] seconds.
WAIT_RUNNING = """
import fcntl, socket, struct, sys, time
name, deadline = sys.argv[1].encode(), time.monotonic() + float(sys.argv[2])
probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
while True:
    request = fcntl.ioctl(probe, 0x8913, struct.pack('16sH14x', name, 0))
    if struct.unpack('16sH14x', request)[1] & 0x40:
        sys.exit(0)
    if time.monotonic() > deadline:
        sys.exit(f'{sys.argv[1]} not running after {sys.argv[2]} s')
    time.sleep(0.02)
"""


def skip_without_namespaces():
    """Skip the calling test, with the reason, where network namespaces cannot be made."""
    import pytest
    if os.geteuid() != 0:
        pytest.skip('needs root: it creates network namespaces (ip netns add)')
    if shutil.which('ip') is None:
        pytest.skip("needs iproute2's ip command")


def ip_command(*arguments, timeout_s=20):
    """Run ``ip ARGUMENTS``; return the completed process (its output captured)."""
    return subprocess.run(['ip', *arguments], capture_output=True, text=True, timeout=timeout_s)


class Child:
    """A process started in a namespace, leading its own process group; its output is kept.

    ``host.namespaces[side]`` names the namespace; ``stdin`` gives the process a pipe that
    :meth:`tell` writes lines to. Lines that start with ``{`` are JSON events (the DDS peer's).
    """

    def __init__(self, host, side, command, env, stdin=False):
        self.started = time.monotonic()
        self.process = subprocess.Popen(
            ['ip', 'netns', 'exec', host.namespaces[side], *command], env=env, cwd=ROOT,
            stdin=subprocess.PIPE if stdin else subprocess.DEVNULL, stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, text=True, start_new_session=True)
        self.lines = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self):
        for line in self.process.stdout:
            self.lines.append(line)

    @property
    def pid(self):
        """The program's own pid: ``ip netns exec`` enters the namespace and execs it."""
        return self.process.pid

    def output(self):
        return ''.join(self.lines[-40:])

    def events(self):
        return [json.loads(line) for line in list(self.lines) if line.startswith('{')]

    def samples(self, topic=None, panel=None):
        return [event for event in self.events() if event.get('event') == 'sample'
                and topic in (None, event['topic']) and panel in (None, event['panel'])]

    def latest(self, topic, panel):
        found = self.samples(topic, panel)
        return found[-1]['value'] if found else None

    def wait_for(self, condition, timeout_s):
        deadline = time.monotonic() + timeout_s
        while not condition():
            if time.monotonic() > deadline or self.process.poll() is not None:
                return condition()
            time.sleep(0.05)
        return True

    def tell(self, line):
        self.process.stdin.write(line + '\n')
        self.process.stdin.flush()

    def stop(self, timeout_s=30.0):
        """SIGINT to the group, SIGKILL to it after ``timeout_s``; return the exit code."""
        for sig in (signal.SIGINT, signal.SIGKILL):
            if self.process.poll() is None:
                try:
                    os.killpg(self.process.pid, sig)
                except ProcessLookupError:
                    pass
            try:
                self.process.wait(timeout=timeout_s)
                break
            except subprocess.TimeoutExpired:
                continue
        self._reader.join(timeout=5.0)
        return self.process.returncode


def shared_memory_mappings(pid):
    """Fast DDS shared-memory segments (transport or data sharing) ``pid`` has mapped."""
    maps = Path(f'/proc/{pid}/maps').read_text()
    return sorted({line.split()[-1] for line in maps.splitlines() if '/dev/shm/fast' in line})
