"""The register map of a Modbus TCP valve terminal: which registers drive and read each channel.

A map (YAML, ``msg_docs/modbus.md``; examples are ``config/modbus_terminal.yaml`` and
``config/modbus_regulators.yaml``) names the terminal's unit id, where each cushion channel's
outputs are, and where its cushion pressure and supply pressure sensors are read (input or
holding registers), with their scaling::

    pressure_pa = offset_pa + pa_per_count * count

A channel's outputs are either its fill and vent valves (holding registers of proportional
valves, or coils of on/off valves) or one proportional pressure regulator: the holding
register of its setpoint, in gauge pressure, with a scaling of its own::

    setpoint_gauge_pa = gauge_offset_pa + gauge_pa_per_count * count

A sensor count outside ``[min_count, max_count]`` (a wire-break or overrange code) reads
NaN, which the pressure loop treats as a sensor dropout. The outputs of all channels, valves
and regulators alike, form one contiguous block and the inputs one block of at most 125
registers, so that a control period is one read and one write (Modbus application protocol
[1]_, function codes 1-16).

References
----------
.. [1] Modbus Organization, "MODBUS Application Protocol Specification V1.1b3", 2012: the
   register and coil tables, and the 125-register read and 123-register write limits.
"""

from dataclasses import dataclass
import math

import numpy as np

from flectofold_model.safe_yaml import read_yaml, short_repr

#: Largest register count one read (function codes 3, 4) may ask for [1].
MAX_READ_REGISTERS = 125
#: Largest register count one write (function code 16) may carry [1].
MAX_WRITE_REGISTERS = 123
#: Largest coil count one write (function code 15) may carry [1].
MAX_WRITE_COILS = 1968
OUTPUT_TABLES = ('holding_registers', 'coils')
INPUT_TABLES = ('input_registers', 'holding_registers')
#: A coil output is switched on for a commanded opening of at least this.
COIL_ON_OPENING = 0.5
_TOP_KEYS = ('unit_id', 'outputs', 'inputs', 'fail_safe', 'channels')


class RegisterMapError(ValueError):
    """A register map that cannot be used; the message names the file and the key."""


@dataclass(frozen=True)
class Sensor:
    """One pressure input register and its scaling to absolute pressure [Pa]."""

    address: int
    pa_per_count: float
    offset_pa: float
    signed: bool = False
    """The register holds a two's-complement int16 (else uint16)."""
    min_count: int = 0
    """Lowest valid count; below it the reading is NaN."""
    max_count: int = 65535
    """Highest valid count; above it the reading is NaN."""

    def decode(self, raw):
        """Absolute pressure [Pa] of raw register values (uint16 array); NaN out of range."""
        count = _counts(raw, self.signed)
        valid = (count >= self.min_count) & (count <= self.max_count)
        return np.where(valid, self.offset_pa + self.pa_per_count * count, np.nan)

    def encode(self, pressure_pa):
        """Raw register value (uint16) of an absolute pressure [Pa], clipped to the range."""
        count = np.rint((np.asarray(pressure_pa, dtype=np.float64) - self.offset_pa)
                        / self.pa_per_count)
        return _raw(count, self.min_count, self.max_count)


@dataclass(frozen=True)
class Regulator:
    """A proportional pressure regulator's setpoint holding register and its scaling [Pa gauge].

    The regulator (a Festo VPPM-style valve) holds its output at the setpoint with its own
    loop, fed from the supply and exhausting to the atmosphere.
    """

    address: int
    gauge_pa_per_count: float
    gauge_offset_pa: float = 0.0
    signed: bool = False
    """The register holds a two's-complement int16 (else uint16)."""
    min_count: int = 0
    """Lowest count the regulator takes; its setpoint there is at most 0 Pa gauge."""
    max_count: int = 65535
    """Highest count the regulator takes."""

    def decode(self, raw):
        """Setpoint [Pa gauge] of raw register values (uint16 array); NaN out of range."""
        count = _counts(raw, self.signed)
        return np.where(self.takes(raw), self.gauge_offset_pa + self.gauge_pa_per_count * count,
                        np.nan)

    def encode(self, gauge_pa):
        """Raw register value (uint16) of a setpoint [Pa gauge], clipped to the range.

        Rounded down, so that the regulator is never set above what was asked: the vent
        setpoint 0 Pa is never a few pascals of pressure, whatever the offset.
        """
        count = np.floor((np.asarray(gauge_pa, dtype=np.float64) - self.gauge_offset_pa)
                         / self.gauge_pa_per_count + 1e-9)
        return _raw(count, self.min_count, self.max_count)

    def takes(self, raw):
        """Whether raw register values (uint16 array) are counts in the regulator's range."""
        count = _counts(raw, self.signed)
        return (count >= self.min_count) & (count <= self.max_count)


def _counts(raw, signed):
    """Return the counts of raw register values: uint16, or int16 where ``signed``."""
    count = np.asarray(raw, dtype=np.int64)
    return np.where(count >= 32768, count - 65536, count) if signed else count


def _raw(count, min_count, max_count):
    """Raw register values (uint16) of counts, NaN and out-of-range clipped to the range."""
    count = np.clip(np.nan_to_num(count, nan=min_count), min_count, max_count).astype(np.int64)
    return np.where(count < 0, count + 65536, count)


@dataclass(frozen=True)
class Channel:
    """One cushion circuit: its fill and vent valve outputs or its regulator, and its sensors."""

    fill: int
    """Fill valve output address; None on a regulator channel."""
    vent: int
    """Vent valve output address; None on a regulator channel."""
    pressure: Sensor
    supply: Sensor
    regulator: Regulator = None
    """The channel's proportional pressure regulator, in place of fill and vent valves."""

    @property
    def outputs(self):
        """``(key, address)`` of each of the channel's outputs, in the order of their keys."""
        if self.regulator is not None:
            return (('regulator.address', self.regulator.address),)
        return (('fill', self.fill), ('vent', self.vent))


@dataclass(frozen=True)
class RegisterMap:
    """A validated register map (build it with :func:`load_register_map` or :func:`parse`)."""

    unit_id: int
    output_table: str
    full_open: int
    """Holding-register value of a fully open proportional valve (counts)."""
    input_table: str
    fail_safe_timeout_s: float
    """The terminal shuts fill, opens vent and sets its regulators to 0 Pa after this long
    without a write [s]."""
    channels: tuple
    source: str = 'register map'

    @property
    def count(self):
        """Number of channels."""
        return len(self.channels)

    @property
    def regulated(self):
        """Which channels a pressure regulator drives (N,) bool."""
        return np.array([c.regulator is not None for c in self.channels], dtype=bool)

    @property
    def output_start(self):
        """First address of the output block."""
        return min(a for c in self.channels for _, a in c.outputs)

    @property
    def output_count(self):
        """Size of the output block (every address in it is a channel's output)."""
        return sum(len(c.outputs) for c in self.channels)

    @property
    def input_start(self):
        """First address of the input block."""
        return min(a for c in self.channels for a in (c.pressure.address, c.supply.address))

    @property
    def input_count(self):
        """Size of the input block, gaps included."""
        last = max(a for c in self.channels for a in (c.pressure.address, c.supply.address))
        return last - self.input_start + 1

    def decode_inputs(self, block):
        """Cushion and supply pressures (N,) [Pa absolute] from the raw input block."""
        block = np.asarray(block, dtype=np.int64)
        if block.shape != (self.input_count,):
            raise ValueError(f'expected {self.input_count} input registers, got '
                             f'{block.shape[0] if block.ndim == 1 else block.shape}')
        start = self.input_start
        pressure = np.array([c.pressure.decode(block[c.pressure.address - start])
                             for c in self.channels], dtype=np.float64)
        supply = np.array([c.supply.decode(block[c.supply.address - start])
                           for c in self.channels], dtype=np.float64)
        return pressure, supply

    def encode_inputs(self, pressure_pa, supply_pa, block=None):
        """Raw input block of absolute pressures (N,) [Pa] (the terminal's side)."""
        block = np.zeros(self.input_count, dtype=np.int64) if block is None else block
        start = self.input_start
        for channel, pressure, supply in zip(self.channels, pressure_pa, supply_pa):
            block[channel.pressure.address - start] = channel.pressure.encode(pressure)
            block[channel.supply.address - start] = channel.supply.encode(supply)
        return block

    def encode_outputs(self, fill_opening, vent_opening, regulator_gauge_pa=None):
        """Return the output block (list of int or bool).

        Valve channels take their openings (N,) in [0, 1], regulator channels their
        setpoints ``regulator_gauge_pa`` (N,) [Pa gauge] (needed when the map has any).
        """
        block = [0] * self.output_count
        start = self.output_start
        coils = self.output_table == 'coils'
        if regulator_gauge_pa is None and np.any(self.regulated):
            raise ValueError(f'{self.source} has regulator channels: their setpoints are '
                             f'needed')
        for i, (channel, fill, vent) in enumerate(zip(self.channels, fill_opening,
                                                      vent_opening)):
            if channel.regulator is not None:
                block[channel.regulator.address - start] = int(
                    channel.regulator.encode(regulator_gauge_pa[i]))
                continue
            for address, opening in ((channel.fill, fill), (channel.vent, vent)):
                block[address - start] = bool(opening >= COIL_ON_OPENING) if coils else \
                    int(round(float(opening) * self.full_open))
        return block

    def outputs_take(self, address, values):
        """Whether the outputs from ``address`` on take the raw ``values`` (the terminal's side).

        A valve's holding register takes ``0..full_open``, a regulator's the counts of its
        range, a coil anything; an address outside the map nothing.
        """
        owners = {a: c for c in self.channels for _, a in c.outputs}
        for offset, value in enumerate(values):
            channel = owners.get(address + offset)
            if channel is None:
                return False
            if self.output_table == 'coils':
                continue
            if channel.regulator is not None:
                if not channel.regulator.takes(value):
                    return False
            elif not 0 <= value <= self.full_open:
                return False
        return True

    def decode_outputs(self, block):
        """Fill and vent openings (N,) in [0, 1] of the output block (the terminal's side).

        A holding register above ``full_open`` is out of range: it reads fully open for a
        vent and shut for a fill valve, the safe side of each. A regulator channel has no
        valve outputs: NaN (its setpoint: :meth:`decode_setpoints`).
        """
        start, full = self.output_start, float(self.full_open)
        fill, vent = np.full(self.count, np.nan), np.full(self.count, np.nan)
        for i, channel in enumerate(self.channels):
            if channel.regulator is not None:
                continue
            raw_fill, raw_vent = block[channel.fill - start], block[channel.vent - start]
            if self.output_table == 'coils':
                fill[i], vent[i] = float(bool(raw_fill)), float(bool(raw_vent))
            else:
                fill[i] = raw_fill / full if raw_fill <= self.full_open else 0.0
                vent[i] = raw_vent / full if raw_vent <= self.full_open else 1.0
        return fill, vent

    def decode_setpoints(self, block):
        """Regulator setpoints (N,) [Pa gauge] of the output block (the terminal's side).

        NaN on valve channels and for a count outside the regulator's range.
        """
        start = self.output_start
        return np.array([np.nan if c.regulator is None else
                         float(c.regulator.decode(block[c.regulator.address - start]))
                         for c in self.channels])


def load_register_map(path):
    """Read and validate the register map YAML at ``path``; :class:`RegisterMapError` if bad."""
    try:
        document = read_yaml(path)
    except OSError as error:
        raise RegisterMapError(f'register map {path}: cannot be read: '
                               f'{error.strerror or error}') from None
    except ValueError as error:
        raise RegisterMapError(str(error)) from None
    return parse(document, str(path))


def parse(document, source='register map'):
    """Validate a register map's plain value (a mapping); :class:`RegisterMapError` if bad."""
    where = _Where(source)
    top = where.mapping('', document, _TOP_KEYS, required=('unit_id', 'outputs', 'inputs',
                                                           'channels'))
    unit_id = where.integer('unit_id', top['unit_id'], 1, 255)
    outputs = where.mapping('outputs', top['outputs'], ('table', 'full_open'), ('table',))
    output_table = where.choice('outputs.table', outputs['table'], OUTPUT_TABLES)
    full_open = 1 if output_table == 'coils' else where.integer(
        'outputs.full_open', outputs.get('full_open', 10000), 1, 65535)
    inputs = where.mapping('inputs', top['inputs'], ('table',), ('table',))
    input_table = where.choice('inputs.table', inputs['table'], INPUT_TABLES)
    fail_safe = where.mapping('fail_safe', top.get('fail_safe', {}), ('timeout_s',), ())
    timeout_s = where.real('fail_safe.timeout_s', fail_safe.get('timeout_s', 0.5), 0.01, 60.0)
    listed = top['channels']
    if not isinstance(listed, list) or not listed:
        where.fail('channels', listed, 'a non-empty list of channels')
    channels = tuple(_channel(where, f'channels[{i}]', entry, output_table)
                     for i, entry in enumerate(listed))
    register_map = RegisterMap(unit_id, output_table, full_open, input_table, timeout_s,
                               channels, source)
    _check_blocks(where, register_map)
    return register_map


def _channel(where, key, entry, output_table):
    entry = where.mapping(key, entry, ('fill', 'vent', 'regulator', 'pressure', 'supply'),
                          ('pressure', 'supply'))
    sensors = (_sensor(where, f'{key}.pressure', entry['pressure']),
               _sensor(where, f'{key}.supply', entry['supply']))
    if 'regulator' not in entry:
        where.mapping(key, entry, entry.keys(), ('fill', 'vent'),
                      ' (a channel has fill and vent valves, or a regulator)')
        return Channel(where.integer(f'{key}.fill', entry['fill'], 0, 65535),
                       where.integer(f'{key}.vent', entry['vent'], 0, 65535), *sensors)
    valves = [k for k in ('fill', 'vent') if k in entry]
    if valves:
        where.fail(f'{key}.{valves[0]}', entry[valves[0]],
                   'absent beside a regulator (a channel has fill and vent valves or a '
                   'regulator, not both)')
    if output_table == 'coils':
        where.fail('outputs.table', output_table, f'holding_registers: {key}.regulator is a '
                   f"pressure regulator's setpoint register")
    return Channel(None, None, *sensors, _regulator(where, f'{key}.regulator',
                                                    entry['regulator']))


def _sensor(where, key, entry):
    entry = where.mapping(key, entry, ('address', 'pa_per_count', 'offset_pa', 'signed',
                                       'min_count', 'max_count'),
                          ('address', 'pa_per_count', 'offset_pa'))
    return Sensor(*_scaled_register(where, key, entry, 'pa_per_count', entry['offset_pa'],
                                    'offset_pa'))


def _regulator(where, key, entry):
    entry = where.mapping(key, entry, ('address', 'gauge_pa_per_count', 'gauge_offset_pa',
                                       'signed', 'min_count', 'max_count'),
                          ('address', 'gauge_pa_per_count'))
    regulator = Regulator(*_scaled_register(where, key, entry, 'gauge_pa_per_count',
                                            entry.get('gauge_offset_pa', 0.0),
                                            'gauge_offset_pa'))
    lowest_pa, highest_pa = (regulator.gauge_offset_pa + regulator.gauge_pa_per_count * count
                             for count in (regulator.min_count, regulator.max_count))
    if lowest_pa > 0.0:  # the vent setpoint must exhaust the cushion
        where.fail(f'{key}.min_count', regulator.min_count,
                   f'a count of at most 0 Pa gauge (the vent setpoint); it sets '
                   f'{lowest_pa:g} Pa with gauge_offset_pa={regulator.gauge_offset_pa:g}')
    if highest_pa <= 0.0:
        where.fail(f'{key}.max_count', regulator.max_count,
                   f'a count above 0 Pa gauge; it sets {highest_pa:g} Pa')
    return regulator


def _scaled_register(where, key, entry, per_count_key, offset, offset_key):
    """Address, scale, offset, signedness and count range of a register, checked."""
    signed = entry.get('signed', False)
    if not isinstance(signed, bool):
        where.fail(f'{key}.signed', signed, 'true or false')
    low, high = (-32768, 32767) if signed else (0, 65535)
    fields = (where.integer(f'{key}.address', entry['address'], 0, 65535),
              where.real(f'{key}.{per_count_key}', entry[per_count_key], 1e-6, 1e6),
              where.real(f'{key}.{offset_key}', offset, -1e7, 1e7), signed,
              where.integer(f'{key}.min_count', entry.get('min_count', low), low, high),
              where.integer(f'{key}.max_count', entry.get('max_count', high), low, high))
    if fields[4] >= fields[5]:
        where.fail(f'{key}.max_count', fields[5], f'more than min_count={fields[4]}')
    return fields


def _check_blocks(where, register_map):
    outputs = {}
    for i, channel in enumerate(register_map.channels):
        for name, address in channel.outputs:
            if address in outputs:
                where.fail(f'channels[{i}].{name}', address,
                           f'an address of its own, not that of {outputs[address]}')
            outputs[address] = f'channels[{i}].{name}'
    start = min(outputs)
    gaps = sorted(set(range(start, start + len(outputs))) - set(outputs))
    if gaps:
        where.fail('channels', f'outputs {start}..{max(outputs)}',
                   f'one contiguous block of outputs (one write per period); address '
                   f'{gaps[0]} is in none')
    largest = MAX_WRITE_COILS if register_map.output_table == 'coils' else MAX_WRITE_REGISTERS
    if len(outputs) > largest:
        where.fail('channels', f'{len(outputs)} outputs', f'at most {largest} in one write')
    pressures = {}
    for i, channel in enumerate(register_map.channels):
        address = channel.pressure.address
        if address in pressures:
            where.fail(f'channels[{i}].pressure.address', address,
                       f'a sensor of its own, not that of channels[{pressures[address]}]')
        pressures[address] = i
    if register_map.input_count > MAX_READ_REGISTERS:
        where.fail('channels', f'inputs {register_map.input_start}..'
                   f'{register_map.input_start + register_map.input_count - 1}',
                   f'one block of at most {MAX_READ_REGISTERS} registers (one read per period)')
    if register_map.input_table == 'holding_registers' and \
            register_map.output_table == 'holding_registers':
        inputs = {a for c in register_map.channels
                  for a in (c.pressure.address, c.supply.address)}
        shared = sorted(inputs & set(outputs))
        if shared:
            where.fail('channels', f'holding register {shared[0]}',
                       'an input or an output, not both')


class _Where:
    """Checks that name the file and the key in their messages."""

    def __init__(self, source):
        self.source = source

    def fail(self, key, value, expected):
        raise RegisterMapError(f'{self.source}: {key or "the document"} must be {expected}, '
                               f'got {short_repr(value)}')

    def mapping(self, key, value, allowed, required, or_else=''):
        if not isinstance(value, dict):
            self.fail(key, value, 'a mapping')
        prefix = f'{key}.' if key else ''
        unknown = [k for k in value if k not in allowed]
        if unknown:
            raise RegisterMapError(f'{self.source}: unknown key {prefix}{unknown[0]} (known: '
                                   f'{", ".join(allowed)})')
        missing = [k for k in required if k not in value]
        if missing:
            raise RegisterMapError(f'{self.source}: {prefix}{missing[0]} is missing{or_else}')
        return value

    def integer(self, key, value, low, high):
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            self.fail(key, value, f'an integer in [{low}, {high}]')
        return value

    def real(self, key, value, low, high):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                not math.isfinite(value) or not low <= value <= high:
            self.fail(key, value, f'a number in [{low:g}, {high:g}]')
        return float(value)

    def choice(self, key, value, choices):
        if value not in choices:
            self.fail(key, value, f'one of {", ".join(choices)}')
        return value
