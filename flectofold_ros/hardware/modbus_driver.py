"""A :class:`~flectofold_model.control.hardware.CushionDriver` for a Modbus TCP valve terminal.

Each control period is one exchange of each kind with the terminal (pymodbus' synchronous
client): :meth:`ModbusCushions.read_pressure_pa` reads the whole input block of the register
map in one request (cushion and supply pressures together; :meth:`read_supply_pa` returns the
supply of that same read), and :meth:`write_outputs` (or :meth:`write_valves` on a terminal
of valves only) writes the whole output block in one: the valve channels' openings and the
regulator channels' pressure setpoints together.

**Comms loss.** A request that times out (``timeout_s``), a dropped or refused connection, or
a Modbus exception reply (a wrong unit id, say) makes :attr:`comms_lost` True: the readings
are NaN and nothing is written until an exchange succeeds again, so a stale command can never
be sent late. The loop then latches ``comms_lost`` on every channel and commands its safe
action, which reaches the terminal as soon as the link is back. Meanwhile the terminal is on
its own: its fieldbus-loss fail-safe must shut the fill valves, open the vents and set the
regulators to 0 Pa (``msg_docs/modbus.md``). A lost connection is reopened with exponential
back-off, from ``backoff_s`` up to ``max_backoff_s``, so that a dead terminal costs one
refused connect per back-off, not a blocked loop every period.
"""

from collections import deque
import math
import time

import numpy as np

from flectofold_model._validate import in_range, real_array
from flectofold_model.actuation.circuit import DEMONSTRATOR_PLANT
from flectofold_model.control.hardware import CushionDriver, openings
from flectofold_ros.hardware.register_map import RegisterMap

#: Exchanges whose timing the driver keeps for its statistics (about 100 s at 10 Hz).
TIMING_HISTORY = 1024
#: Modbus exception codes and what they mean [1] (register_map.py's reference).
EXCEPTIONS = {1: 'illegal function', 2: 'illegal data address', 3: 'illegal data value',
              4: 'server device failure', 6: 'server device busy',
              10: 'gateway path unavailable',
              11: 'gateway target device failed to respond (no such unit id?)'}


class ModbusCushions(CushionDriver):
    """The channels of one Modbus TCP valve terminal, as its register map lays them out.

    Parameters
    ----------
    register_map : RegisterMap
        Registers and scaling of every channel (:func:`~.register_map.load_register_map`).
    host : str
        The terminal's address.
    port : int
        Its Modbus TCP port (502 by default on terminals).
    circuit : PlantParameters
        Valves and tubing of the channels, for the loop's model.
    timeout_s : float
        Longest wait for a connection or a reply [s]; less than the control period.
    backoff_s, max_backoff_s : float
        First and longest wait before reconnecting after a failure [s].
    client_factory : callable
        ``client_factory(host, port, timeout_s)`` -> a pymodbus-like client (tests).
    """

    def __init__(self, register_map, host, port, circuit=DEMONSTRATOR_PLANT, timeout_s=0.05,
                 backoff_s=0.1, max_backoff_s=2.0, client_factory=None):
        if not isinstance(register_map, RegisterMap):
            raise TypeError(f'register_map must be a RegisterMap, got '
                            f'{type(register_map).__name__}')
        self.map = register_map
        self.host, self.port = validate_endpoint(host, port)
        for name, value in (('timeout_s', timeout_s), ('backoff_s', backoff_s),
                            ('max_backoff_s', max_backoff_s)):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                    not 0.0 < value <= 60.0:
                raise ValueError(f'{name} must be a number in (0, 60] s, got {value!r}')
        self.timeout_s, self.backoff_s = float(timeout_s), float(backoff_s)
        self.max_backoff_s = max(float(max_backoff_s), self.backoff_s)
        self._circuit = circuit
        self._client = (client_factory or _pymodbus_client)(self.host, self.port,
                                                            self.timeout_s)
        self._connected = False
        self._lost = True  # nothing read yet
        self._next_attempt_s = -math.inf
        self._backoff = self.backoff_s
        nan = np.full(register_map.count, np.nan)
        self._pressure, self._supply = nan, nan.copy()
        self._regulator_gauge_pa = np.zeros(register_map.count)
        self.last_error = ''
        self.exchanges, self.failures, self.reconnects, self.writes_skipped = 0, 0, 0, 0
        self.round_trips_s = deque(maxlen=TIMING_HISTORY)
        """Wall-clock time of each successful read-and-write exchange pair [s]."""
        self.read_times_s = deque(maxlen=TIMING_HISTORY)
        """Monotonic time of each read, for the loop period's jitter [s]."""
        self._read_started = None

    @property
    def count(self):
        return self.map.count

    @property
    def circuit(self):
        return self._circuit

    @property
    def comms_lost(self):
        return self._lost

    @property
    def regulated(self):
        return self.map.regulated

    @property
    def regulator_gauge_pa(self):
        """The regulator setpoints last asked for (N,) [Pa gauge], written or not."""
        return self._regulator_gauge_pa.copy()

    # -- the exchanges ---------------------------------------------------------------------

    def read_pressure_pa(self):
        """Read every input of the terminal (one request); cushion pressures (N,) [Pa]."""
        started = time.monotonic()
        self.read_times_s.append(started)
        self._read_started = None
        nan = np.full(self.count, np.nan)
        self._pressure, self._supply = nan, nan.copy()
        if not self._ensure_connected(started):
            return self._pressure.copy()
        reader = self._client.read_input_registers if self.map.input_table == \
            'input_registers' else self._client.read_holding_registers
        reply = self._request(reader, self.map.input_start, count=self.map.input_count,
                              device_id=self.map.unit_id)
        if reply is None:
            return self._pressure.copy()
        registers = list(reply.registers)
        if len(registers) != self.map.input_count:
            self._fail(f'the terminal answered {len(registers)} registers for '
                       f'{self.map.input_count}', disconnect=True)
            return self._pressure.copy()
        self._pressure, self._supply = self.map.decode_inputs(registers)
        self._lost = False
        self._read_started = started
        return self._pressure.copy()

    def read_supply_pa(self):
        """Supply pressures (N,) [Pa] of the last :meth:`read_pressure_pa`."""
        return self._supply.copy()

    def write_valves(self, fill_opening, vent_opening):
        """Write every output of the terminal (one request); nothing while comms are lost.

        Regulator channels keep the setpoints last asked for (0 Pa before any).
        """
        self.write_outputs(fill_opening, vent_opening, self._regulator_gauge_pa)

    def write_outputs(self, fill_opening, vent_opening, regulator_gauge_pa):
        """Write valve openings and regulator setpoints [Pa gauge] (N,) in one request.

        Nothing is written while comms are lost. A setpoint beyond a regulator's range is
        written as its nearest end.
        """
        fill = openings('fill_opening', fill_opening, self.count)
        vent = openings('vent_opening', vent_opening, self.count)
        setpoint = np.broadcast_to(real_array('regulator_gauge_pa', regulator_gauge_pa),
                                   (self.count,))
        self._regulator_gauge_pa = in_range('regulator_gauge_pa', setpoint, 0.0,
                                            np.inf).astype(np.float64)
        if self._lost or not self._connected:
            self.writes_skipped += 1
            return
        block = self.map.encode_outputs(fill, vent, self._regulator_gauge_pa)
        writer = self._client.write_coils if self.map.output_table == 'coils' else \
            self._client.write_registers
        if self._request(writer, self.map.output_start, block,
                         device_id=self.map.unit_id) is None:
            return
        self.exchanges += 1
        if self._read_started is not None:
            self.round_trips_s.append(time.monotonic() - self._read_started)

    def close(self):
        """Shut every valve if the terminal answers, then close the connection.

        The regulators keep their setpoints: like valves shut, they hold the cushions' air.
        """
        try:
            if self._connected and not self._lost:
                self.write_valves(np.zeros(self.count), np.zeros(self.count))
        finally:
            self._client.close()
            self._connected = False

    # -- the link --------------------------------------------------------------------------

    def _ensure_connected(self, now_s):
        if self._connected:
            return True
        if now_s < self._next_attempt_s:
            return False
        if self._client.connect():
            self._connected = True
            self.reconnects += 1
            return True
        self._fail(f'cannot connect to {self.host}:{self.port}')
        return False

    def _request(self, call, *args, **kwargs):
        """Run one request; return its reply, or None after recording the failure."""
        from pymodbus.exceptions import ModbusException
        try:
            reply = call(*args, **kwargs)
        except (ModbusException, OSError) as error:
            self._fail(f'{self.host}:{self.port} unit {self.map.unit_id}: '
                       f'{" ".join(str(error).split()) or type(error).__name__}',
                       disconnect=True)
            return None
        if reply.isError():
            code = getattr(reply, 'exception_code', None)
            self._fail(f'{self.host}:{self.port} unit {self.map.unit_id} refused the request: '
                       f'Modbus exception {code} ({EXCEPTIONS.get(code, "unknown")})')
            return None
        self._backoff = self.backoff_s
        return reply

    def _fail(self, reason, disconnect=False):
        """Comms lost: NaN readings, no writes, reconnect after the back-off."""
        self._lost = True
        self.failures += 1
        self.last_error = reason
        self._pressure = np.full(self.count, np.nan)
        self._supply = self._pressure.copy()
        self._read_started = None
        if disconnect or not self._connected:
            # a late reply must not be taken for the next request's: a new connection
            self._client.close()
            self._connected = False
            self._next_attempt_s = time.monotonic() + self._backoff
            self._backoff = min(2.0 * self._backoff, self.max_backoff_s)

    # -- statistics ------------------------------------------------------------------------

    def statistics(self, period_s):
        """Figures for ``/diagnostics``: link state, round trip and period jitter p50/p99 [s].

        The kept timings are taken (cleared) by the call. ``period_s``: the nominal period.
        """
        round_trips = np.array(self.round_trips_s)
        intervals = np.diff(np.array(self.read_times_s))
        self.round_trips_s.clear()
        last = self.read_times_s[-1] if self.read_times_s else None
        self.read_times_s.clear()
        if last is not None:
            self.read_times_s.append(last)
        jitter = np.abs(intervals - period_s)

        def percentiles(values):
            return tuple(float(v) for v in np.percentile(values, [50, 99])) if len(values) \
                else (math.nan, math.nan)

        (rt50, rt99), (j50, j99) = percentiles(round_trips), percentiles(jitter)
        return {
            'modbus_terminal': f'{self.host}:{self.port} unit {self.map.unit_id}',
            'comms': 'lost' if self._lost else 'ok',
            'modbus_last_error': self.last_error,
            'modbus_exchanges': self.exchanges, 'modbus_failures': self.failures,
            'modbus_connects': self.reconnects, 'modbus_writes_skipped': self.writes_skipped,
            'modbus_round_trip_p50_s': rt50, 'modbus_round_trip_p99_s': rt99,
            'loop_period_jitter_p50_s': j50, 'loop_period_jitter_p99_s': j99,
        }


def validate_endpoint(host, port):
    """Return ``(host, port)`` checked: a non-empty host name or address, a port in 1-65535."""
    if not isinstance(host, str) or not host or len(host) > 253 or \
            any(c.isspace() or c in '/\\@' for c in host):
        raise ValueError(f'modbus host must be a host name or an IP address, got {host!r}')
    if isinstance(port, bool) or not isinstance(port, int) or not 1 <= port <= 65535:
        raise ValueError(f'modbus port must be an integer in [1, 65535], got {port!r}')
    return host, port


def _pymodbus_client(host, port, timeout_s):
    from pymodbus.client import ModbusTcpClient
    # retries=0: a lost reply is comms lost at once, not a period-long block
    return ModbusTcpClient(host, port=port, timeout=timeout_s, retries=0)
