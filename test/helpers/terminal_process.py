"""Start ``valve_terminal_sim`` in its own process for a test and find its port."""

import os
from pathlib import Path
import re
import signal
import subprocess
import sys
import threading

EXAMPLE_MAP = Path(__file__).resolve().parents[2] / 'config' / 'modbus_terminal.yaml'
REGULATOR_MAP = EXAMPLE_MAP.with_name('modbus_regulators.yaml')
# A Modbus timeout for tests not about timeouts: three test workers on two cores can hold the
# terminal's reply past the driver's 50 ms default, and ``comms_lost`` would latch; with other
# work on the machine too (load 10 on 2 cores) replies came past 0.25 s. The parameter's most.
UNHURRIED_TIMEOUT_S = 1.0
_SERVING = re.compile(r'serving \d+ channel\(s\) of unit \d+ on ([\d.]+):(\d+)')


class Terminal:
    """A ``valve_terminal_sim`` process; ``port`` is the one it bound."""

    def __init__(self, *arguments, port=0, map_file=EXAMPLE_MAP, env=None, timeout_s=60.0):
        command = [sys.executable, '-m', 'flectofold_ros', 'valve_terminal_sim',
                   '--map', str(map_file), '--port', str(port), *arguments]
        self.process = subprocess.Popen(command, stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, text=True,
                                        env=env or dict(os.environ, PYTHONUNBUFFERED='1'))
        self.lines = []
        found = threading.Event()

        def read():
            for line in self.process.stdout:
                self.lines.append(line)
                if _SERVING.search(line):
                    found.set()
            found.set()

        threading.Thread(target=read, daemon=True).start()
        found.wait(timeout_s)
        match = next((_SERVING.search(line) for line in self.lines if _SERVING.search(line)),
                     None)
        if match is None:
            self.kill()
            raise RuntimeError(f'the terminal did not start: {"".join(self.lines)}')
        self.host, self.port = match.group(1), int(match.group(2))

    def stop(self, sig=signal.SIGINT, timeout_s=30.0):
        """Signal the process; return its exit code."""
        if self.process.poll() is None:
            self.process.send_signal(sig)
        return self.process.wait(timeout=timeout_s)

    def kill(self):
        """End it at once (a terminal losing power); return its exit code."""
        if self.process.poll() is None:
            self.process.kill()
        return self.process.wait(timeout=30.0)


def read_registers(port, address, count, table='holding', unit_id=1):
    """Read a terminal's registers with a client of its own (not the driver's)."""
    from pymodbus.client import ModbusTcpClient
    client = ModbusTcpClient('127.0.0.1', port=port, timeout=2.0, retries=1)
    try:
        assert client.connect()
        call = client.read_holding_registers if table == 'holding' else \
            client.read_input_registers
        reply = call(address, count=count, device_id=unit_id)
        assert not reply.isError(), reply
        return list(reply.registers)
    finally:
        client.close()
