"""Modbus figures: round-trip latency and loop period jitter against ``valve_terminal_sim``.

Run with ``.venv/bin/python bench/bench_modbus.py [--duration-s 30] [--period-s 0.1]
[--map config/modbus_regulators.yaml]``. It starts the simulated terminal (by default the
example map ``config/modbus_terminal.yaml``, two valve channels; ``--map`` another, such as
the two regulator channels of ``config/modbus_regulators.yaml``) in its own process on
127.0.0.1, runs :class:`PanelLoops` over :class:`ModbusCushions` on the wall clock at the
given period, as a panel process does (one batched read and one batched write per period),
and prints:

* the round trip of each period's exchange (read request sent to write reply received) and
  of the read alone, p50/p99/max;
* the loop period jitter: how far the interval between two reads strayed from the period;
* CPU time per period of the loop and of the terminal process.

The first :data:`WARM_UP` periods are not measured (the loop's kernels load in them).

Everything printed is measured here, on this machine.
"""

import argparse
from pathlib import Path
import re
import subprocess
import sys
import time

import numpy as np

from flectofold_model.actuation import actuated_like, actuation_model_of, CushionMap
from flectofold_model.control import compile_kernels, ControllerParameters, PanelLoops
from flectofold_model.facade import load_facade
from flectofold_ros.hardware.modbus_driver import ModbusCushions
from flectofold_ros.hardware.register_map import load_register_map

#: Periods run before the measurement.
WARM_UP = 10
MAP = Path(__file__).resolve().parents[1] / 'config' / 'modbus_terminal.yaml'


def start_terminal(map_file):
    process = subprocess.Popen([sys.executable, '-m', 'flectofold_ros', 'valve_terminal_sim',
                                '--map', str(map_file), '--port', '0'],
                               stdout=subprocess.PIPE, text=True)
    line = process.stdout.readline()
    match = re.search(r'on ([\d.]+):(\d+)', line)
    if match is None:
        process.kill()
        raise SystemExit(f'the terminal did not start: {line!r}')
    return process, int(match.group(2))


def cpu_s(pid):
    """User + system CPU time of process ``pid`` [s] (Linux /proc)."""
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    import os
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


class TimedDriver(ModbusCushions):
    """ModbusCushions that also times the read alone."""

    reads_s = []

    def read_pressure_pa(self):
        started = time.perf_counter()
        result = super().read_pressure_pa()
        self.reads_s.append(time.perf_counter() - started)
        return result


def percentiles(values_s):
    p50, p99 = np.percentile(values_s, [50, 99])
    return f'p50 {p50 * 1e3:7.3f} ms   p99 {p99 * 1e3:7.3f} ms   max {max(values_s) * 1e3:7.3f} ms'


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--duration-s', type=float, default=30.0)
    parser.add_argument('--period-s', type=float, default=0.1)
    parser.add_argument('--map', default=str(MAP), help='register map of the terminal')
    options = parser.parse_args()
    register_map = load_register_map(options.map)
    facade = load_facade()
    model = actuation_model_of(actuated_like(facade.panels[i])
                               for i in range(register_map.count))
    terminal, port = start_terminal(options.map)
    try:
        driver = TimedDriver(register_map, '127.0.0.1', port)
        loops = PanelLoops(model, driver, options.period_s,
                           ControllerParameters(time_constant_s=max(0.4, 2 * options.period_s),
                                                hold_band_pa=60.0),
                           cushion_map=CushionMap(model))
        compile_kernels()  # as a panel process does before its first tick
        loops.advance_to(time.monotonic())
        for _ in range(WARM_UP):  # the first periods load the loop's compiled kernel
            time.sleep(options.period_s)
            loops.advance_to(time.monotonic())
        driver.round_trips_s.clear()
        driver.read_times_s.clear()
        driver.reads_s.clear()
        exchanges = driver.exchanges
        round_trips, intervals = [], []
        periods = int(options.duration_s / options.period_s)
        cpu_start, terminal_cpu_start = time.process_time(), cpu_s(terminal.pid)
        start = time.monotonic()
        for k in range(1, periods + 1):
            setpoints = np.full(register_map.count, 0.5)
            setpoints[0] = 0.3 + 0.4 * (k // 50 % 2)  # a step every 50 periods
            loops.set_setpoints(setpoints)
            deadline = start + k * options.period_s
            time.sleep(max(0.0, deadline - time.monotonic()))
            loops.advance_to(time.monotonic())
            if len(driver.round_trips_s) >= 512:
                round_trips += driver.round_trips_s
                driver.round_trips_s.clear()
            if len(driver.read_times_s) >= 512:
                intervals += np.diff(np.array(driver.read_times_s)).tolist()
                last = driver.read_times_s[-1]
                driver.read_times_s.clear()
                driver.read_times_s.append(last)
        loop_cpu = time.process_time() - cpu_start
        terminal_cpu = cpu_s(terminal.pid) - terminal_cpu_start
        round_trips += driver.round_trips_s
        intervals += np.diff(np.array(driver.read_times_s)).tolist()
        jitter = np.abs(np.array(intervals) - options.period_s)
        regulators = int(register_map.regulated.sum())
        print(f'== Modbus TCP to valve_terminal_sim on 127.0.0.1: {periods} periods of '
              f'{options.period_s * 1e3:g} ms, {loops.driver.count} channels '
              f'({regulators} regulated), {Path(options.map).name} ==')
        faults = sorted({f.value for f in loops.fault})
        print(f'failures {driver.failures}, connects {driver.reconnects}, '
              f'exchanges {driver.exchanges - exchanges}, faults {faults}')
        print(f'round trip (read + write)  {percentiles(round_trips)}')
        print(f'read alone                 {percentiles(driver.reads_s)}')
        print(f'loop period jitter         {percentiles(jitter.tolist())}')
        print(f'CPU per period: loop {loop_cpu / periods * 1e3:.3f} ms, terminal '
              f'{terminal_cpu / periods * 1e3:.3f} ms (the terminal also steps its plant '
              f'every 10 ms)')
        loops.close()
    finally:
        terminal.terminate()
        terminal.wait(timeout=10)


if __name__ == '__main__':
    main()
