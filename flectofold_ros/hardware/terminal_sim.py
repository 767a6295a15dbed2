"""A simulated Modbus TCP valve terminal: the simulated plant behind a register map.

:class:`SimulatedTerminal` holds the terminal's registers and a
:class:`~flectofold_model.actuation.PneumaticPlant` with one channel per map channel, as
:class:`~flectofold_model.control.hardware.SimulatedCushions` does, and advances the plant on
the wall clock with the valve openings its output registers hold; on a regulator channel a
simulated proportional pressure regulator (:mod:`.regulator_sim`) drives that channel's
valves toward the setpoint its register holds. It keeps the fieldbus-loss fail-safe the map
asks a real terminal to be configured with: after ``fail_safe.timeout_s`` without a write,
every fill valve shuts, every vent opens and every regulator is set to 0 Pa, exhausting
(until the next write). :func:`serve` puts it behind pymodbus' asyncio TCP server, bound to
127.0.0.1 unless told otherwise; the ``valve_terminal_sim`` executable runs that.
"""

import asyncio
import time

import numpy as np
from pymodbus.constants import ExcCodes
from pymodbus.datastore import ModbusServerContext
from pymodbus.exceptions import NoSuchIdException

from flectofold_model.actuation import PneumaticPlant
from flectofold_model.actuation.circuit import DEMONSTRATOR_PLANT
from flectofold_model.control.panel_loops import facade_actuation, facade_plant
from flectofold_ros.hardware.regulator_sim import regulator_openings

#: Address the simulator listens on unless told otherwise: this host only.
DEFAULT_HOST = '127.0.0.1'
#: Longest plant step the terminal takes [s]; it steps at least this often while serving.
STEP_S = 0.01
_READ_CODES = {3: 'holding', 4: 'input', 1: 'coils'}


class SimulatedTerminal:
    """Registers and plant of a simulated valve terminal.

    Parameters
    ----------
    register_map : RegisterMap
        The map the terminal serves.
    plant : PneumaticPlant
        ``register_map.count`` channels.
    response_delay_s : float
        Every reply waits this long (a slow or overloaded terminal) [s].
    forced_inputs : dict
        ``{address: raw count}`` input registers held at a value whatever the plant does
        (a broken sensor's fault code).
    clock : callable
        Monotonic wall clock [s].
    """

    def __init__(self, register_map, plant, response_delay_s=0.0, forced_inputs=None,
                 clock=time.monotonic):
        if not isinstance(plant, PneumaticPlant) or plant.count != register_map.count:
            raise ValueError(f'the plant must be a PneumaticPlant of {register_map.count} '
                             f'channels')
        self.map, self.plant, self.clock = register_map, plant, clock
        self.response_delay_s = float(response_delay_s)
        self.forced_inputs = dict(forced_inputs or {})
        for address in self.forced_inputs:
            if not 0 <= address - register_map.input_start < register_map.input_count:
                raise ValueError(f'forced input {address} is not in the input block '
                                 f'{register_map.input_start}..'
                                 f'{register_map.input_start + register_map.input_count - 1}')
        self.outputs = [False if register_map.output_table == 'coils' else 0] * \
            register_map.output_count
        self.inputs = np.zeros(register_map.input_count, dtype=np.int64)
        self.time_s = clock()
        self.last_write_s = None
        self.fail_safe_active = False
        self.writes, self.reads = 0, 0
        self._sample()

    def openings(self):
        """Give the fill and vent valve positions in force (N,).

        The outputs' or the fail-safe's on a valve channel, the regulator's on a regulator
        channel (toward :meth:`setpoints_gauge_pa`, from the plant's present pressure).
        """
        if self.fail_safe_active:
            fill, vent = np.zeros(self.map.count), np.ones(self.map.count)
        else:
            fill, vent = self.map.decode_outputs(self.outputs)
        regulated = self.map.regulated
        if np.any(regulated):
            regulator_fill, regulator_vent = regulator_openings(self.plant,
                                                                self.setpoints_gauge_pa())
            fill = np.where(regulated, regulator_fill, fill)
            vent = np.where(regulated, regulator_vent, vent)
        return fill, vent

    def setpoints_gauge_pa(self):
        """Give the regulator setpoints in force (N,) [Pa gauge]: 0 under the fail-safe.

        NaN on valve channels; an out-of-range count (never written: refused) reads NaN,
        which the regulator takes as 0 Pa.
        """
        setpoint = self.map.decode_setpoints(self.outputs)
        if self.fail_safe_active:
            setpoint[self.map.regulated] = 0.0
        return setpoint

    def advance(self):
        """Run the plant up to the wall clock, with the openings in force."""
        now = self.clock()
        if self.last_write_s is not None and \
                now - self.last_write_s > self.map.fail_safe_timeout_s:
            self.fail_safe_active = True
        while now - self.time_s > 1e-6:
            step = min(STEP_S, now - self.time_s)
            self.plant.step(step, *self.openings())
            self.time_s += step
        self._sample()

    def _sample(self):
        self.map.encode_inputs(self.plant.read_sensor(), self.plant.read_supply_sensor(),
                               self.inputs)
        for address, count in self.forced_inputs.items():
            self.inputs[address - self.map.input_start] = count & 0xFFFF

    # -- the Modbus side -------------------------------------------------------------------

    def get(self, table, address, count):
        """Values of ``count`` registers or coils from ``address``; ExcCodes if out of map."""
        self.advance()
        self.reads += 1
        if table == self._input_table():
            block, start = self.inputs.tolist(), self.map.input_start
        elif table == self._output_table():
            block, start = list(self.outputs), self.map.output_start
        else:
            return ExcCodes.ILLEGAL_FUNCTION
        if address < start or address + count > start + len(block):
            return ExcCodes.ILLEGAL_ADDRESS
        return block[address - start:address - start + count]

    def put(self, table, address, values):
        """Write outputs; None, or ExcCodes for an address or table outside the outputs."""
        self.advance()
        if table != self._output_table():
            return ExcCodes.ILLEGAL_ADDRESS
        start = self.map.output_start
        if address < start or address + len(values) > start + len(self.outputs):
            return ExcCodes.ILLEGAL_ADDRESS
        if not self.map.outputs_take(address, values):
            return ExcCodes.ILLEGAL_VALUE  # the outputs in force stay as they were
        self.outputs[address - start:address - start + len(values)] = list(values)
        self.last_write_s, self.fail_safe_active = self.clock(), False
        self.writes += 1
        return None

    def _input_table(self):
        return 'input' if self.map.input_table == 'input_registers' else 'holding'

    def _output_table(self):
        return 'coils' if self.map.output_table == 'coils' else 'holding'


class _TerminalContext(ModbusServerContext):
    """pymodbus' datastore interface over a :class:`SimulatedTerminal` (one unit id)."""

    def __init__(self, terminal):  # noqa: D107 - no base initialiser: no pymodbus datastore
        self.terminal = terminal
        self.old_simulator, self.simdevices, self._devices = True, [], {}

    def _check(self, device_id):
        if device_id != self.terminal.map.unit_id:
            raise NoSuchIdException(f'unit id {device_id} is not {self.terminal.map.unit_id}')

    async def async_getValues(self, device_id, func_code, address, count=1):  # noqa: N802
        self._check(device_id)
        if self.terminal.response_delay_s:
            await asyncio.sleep(self.terminal.response_delay_s)
        table = {1: 'coils', 3: 'holding', 4: 'input', 5: 'coils', 6: 'holding', 15: 'coils',
                 16: 'holding', 23: 'holding'}.get(func_code)
        if table is None:
            return ExcCodes.ILLEGAL_FUNCTION
        return self.terminal.get(table, address, count)

    async def async_setValues(self, device_id, func_code, address, values):  # noqa: N802
        self._check(device_id)
        if self.terminal.response_delay_s:
            await asyncio.sleep(self.terminal.response_delay_s)
        table = {5: 'coils', 15: 'coils', 6: 'holding', 16: 'holding', 23: 'holding'}.get(
            func_code)
        if table is None:
            return ExcCodes.ILLEGAL_FUNCTION
        return self.terminal.put(table, address, list(values))

    def device_ids(self):
        return [self.terminal.map.unit_id]


def terminal_plant(register_map, facade, panel_ids=None, circuit=DEMONSTRATOR_PLANT, seed=0):
    """Build the simulated plant of a terminal for ``panel_ids`` of ``facade``, one a channel.

    ``panel_ids`` None: the facade's first ``register_map.count`` panels.
    """
    panel_ids = list(facade.panel_ids[:register_map.count] if panel_ids is None else panel_ids)
    if len(panel_ids) != register_map.count:
        raise ValueError(f'{register_map.source} has {register_map.count} channel(s) for '
                         f'{len(panel_ids)} panel(s)')
    return facade_plant(*facade_actuation(facade, panel_ids, trace=False), circuit, seed)


async def serve(terminal, host=DEFAULT_HOST, port=0, started=None, stop=None):
    """Serve ``terminal`` on ``host:port`` (port 0: a free one) until ``stop()`` is true.

    ``started(host, port)`` is called once listening, with the port bound.
    """
    from pymodbus.server import ModbusTcpServer
    terminal.advance()  # the first plant step loads its compiled kernel: before serving
    server = ModbusTcpServer(_TerminalContext(terminal), address=(host, port))
    try:
        await server.serve_forever(background=True)
    except RuntimeError:
        raise ValueError(f'cannot listen on {host}:{port} (in use, or not an address of this '
                         f'host)') from None
    bound = server.transport.sockets[0].getsockname()[1]
    if started is not None:
        started(host, bound)
    try:
        while stop is None or not stop():
            terminal.advance()
            await asyncio.sleep(STEP_S)
    finally:
        await server.shutdown()
