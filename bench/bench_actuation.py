"""Actuation figures: presets, fold-radius trade-off, pressure-loop step, plant speed.

Run with ``.venv/bin/python bench/bench_actuation.py``. Everything printed is computed here,
from flectofold_model; nothing is copied from elsewhere.
"""

import copy
import math

from _timing import best_and_median
import numpy as np

from flectofold_model.actuation import (ActuationModel, CushionMap, DEMONSTRATOR_ACTUATED,
                                        DEMONSTRATOR_PLANT, FLECTOLINE_ACTUATED,
                                        physical_fill_time_s, PneumaticPlant, radius_study)
from flectofold_model.control.loop_simulation import simulate, step_metrics
from flectofold_model.control.pressure_loop import PressureController

STEPPING = {False: 'fixed', True: 'adaptive'}  # the RK4 plant's two sub-step rules


def presets():
    model = ActuationModel([DEMONSTRATOR_ACTUATED, FLECTOLINE_ACTUATED])
    print('== presets: gauge pressure [kPa] that holds each closure ==')
    closures = np.linspace(0.0, 1.0, 6)
    print('closure      ' + ' '.join(f'{c:6.1f}' for c in closures))
    for index, name in enumerate(('demonstrator', 'flectoline-like')):
        pressures = [abs(model.pressure_from_closure(c)[index]) / 1e3 for c in closures]
        print(f'{name:<13}' + ' '.join(f'{p:6.2f}' for p in pressures))
    closure_90 = model.fold.closure_from_fold_angle(math.radians(90.0))
    volume = model.cushion_volume_m3(model.fold.closed_k)
    print(f'demonstrator: closed at {model.closed_pressure_pa[0] / 1e3:.2f} kPa (published '
          f'working range 4-9 kPa), cushion {volume[0] * 1e3:.1f} L when closed, '
          f'actuation energy {model.actuation_energy_j[0]:.1f} J')
    pressure_90 = model.pressure_from_closure(closure_90)[1]
    print(f'flectoline-like: 90 deg apex fold at {pressure_90 / 1e3:.1f} kPa (published 30-40 '
          f'kPa), cushion {volume[1] * 1e3:.2f} L when closed')


def tradeoff():
    study = radius_study((0.5, 0.75, 1.0))
    closed = study.fold.state_from_closure(1.0)
    wind = study.wind_response(1000.0)
    strain = [panel.midrib.surface_strain(curvature) for panel, curvature
              in zip(study.panels, closed.midrib_peak_curvature_per_m)]
    print('\n== fold-radius trade-off, 520 x 420 mm panel closed, 1.0 kN/m2 on the flaps ==')
    print(f'{"radius [mm]":>11} {"energy [J]":>10} {"pressure [kPa]":>14} '
          f'{"supports [mm]":>13} {"mid-rib [mm]":>12} {"wind tip [mm]":>13} '
          f'{"stiffness [N/m]":>15} {"mid-rib strain":>14}')
    for i, radius in enumerate((500, 750, 1000)):
        print(f'{radius:>11} {study.actuation_energy_j[i]:>10.2f} '
              f'{study.closed_pressure_pa[i] / 1e3:>14.1f} '
              f'{closed.support_displacement_m[i] * 1e3:>13.1f} '
              f'{study.batch.midrib_width_m[i] * 1e3:>12.0f} '
              f'{wind.tip_deflection_m[i] * 1e3:>13.1f} {wind.stiffness_n_per_m[i]:>15.0f} '
              f'{strain[i] * 100:>13.2f}%')
    print('energy = integral p dV open -> closed (= stored elastic energy); wind tip = travel of '
          'tip A with the cushion pressure held')


def step_response():
    table = CushionMap(ActuationModel([DEMONSTRATOR_ACTUATED]))
    closed = table.pressure_pa[0, -1]
    fill_time = physical_fill_time_s(DEMONSTRATOR_PLANT, table, closed)
    controller = PressureController(table, DEMONSTRATOR_PLANT)
    plant = PneumaticPlant(DEMONSTRATOR_PLANT, table, 1, seed=1)
    trace = simulate(controller, plant, lambda t: 0.0 if t < 1.0 else 1.0, 1.0 + 2 * fill_time)
    metrics = step_metrics(trace, 0, step_time_s=1.0)
    print('\n== pressure loop, demonstrator module, open -> closed step at t = 1 s ==')
    print(f'target {closed / 1e3:.2f} kPa; physical fill time (fill valve wide open) '
          f'{fill_time:.2f} s')
    print(f'settling to 2 %: {metrics.settling_time_s:.2f} s = '
          f'{metrics.settling_time_s / fill_time:.2f} x fill time (limit 1.50)')
    print(f'overshoot {metrics.overshoot_fraction * 100:.2f} % (limit 5 %); steady error '
          f'{metrics.steady_error_fraction * 100:.3f} % of the step over the last 5 s with '
          f'{DEMONSTRATOR_PLANT.sensor_noise_pa:g} Pa sensor noise (limit 1 %)')
    print(f'free air used {plant.free_air_used_m3[0] * 1e3:.1f} NL; final closure '
          f'{trace.closure[-1, 0]:.3f}')


def plant_speed(count=36, period_s=0.1, hold_s=10.0, fill_s=15.0, repeats=2):
    """Time the closed loop on the fixed 1 ms and the adaptive sub-step, quiet and filling."""
    table = CushionMap(ActuationModel([DEMONSTRATOR_ACTUATED] * count))
    print(f'\n== plant speed: {count} demonstrator panels, closed loop at {period_s:g} s ==')
    print(f'simulated seconds per second of compute (median of {repeats}, one process), and '
          f'sub-steps per control period')

    def compare(label, start, setpoint, duration_s):
        """Run ``start(adaptive) -> (controller, plant)`` on both plants and print."""
        figures = {}
        for adaptive in (False, True):
            runs = []

            def once():
                controller, plant = start(adaptive)
                trace = simulate(controller, plant, setpoint, duration_s, period_s)
                runs.append((trace.gauge_pa, plant.substeps_taken))

            median = best_and_median(once, repeats)[1]
            gauge, substeps = runs[-1]
            figures[adaptive] = duration_s / median, substeps * period_s / duration_s, gauge
        (fixed, fixed_steps, fixed_gauge), (fast, fast_steps, fast_gauge) = (
            figures[False], figures[True])
        gap = np.max(np.abs(fast_gauge - fixed_gauge))
        print(f'{label:<28} fixed {fixed:6.1f} s/s ({fixed_steps:4.0f})   adaptive '
              f'{fast:6.1f} s/s ({fast_steps:5.1f})   x{fast / fixed:4.1f}   true pressures '
              f'within {gap:.1g} Pa')

    for closure in (1.0, 0.5):
        controller = PressureController(table, DEMONSTRATOR_PLANT)
        plant = PneumaticPlant(DEMONSTRATOR_PLANT, table, count, seed=2, integrator='adaptive')
        simulate(controller, plant, closure, 20.0, period_s)  # fill and settle, untimed

        def held(adaptive, controller=controller, gauge=plant.gauge_pressure_pa):
            return copy.deepcopy(controller), PneumaticPlant(
                DEMONSTRATOR_PLANT, table, count, seed=3, integrator=STEPPING[adaptive],
                initial_gauge_pa=gauge)

        compare(f'(a) hold at closure {closure:g}', held, closure, hold_s)

    def vented(adaptive):
        return (PressureController(table, DEMONSTRATOR_PLANT),
                PneumaticPlant(DEMONSTRATOR_PLANT, table, count, seed=3,
                               integrator=STEPPING[adaptive]))

    compare('(b) full fill 0 -> 1', vented, 1.0, fill_s)

    def shut(adaptive):
        plant = PneumaticPlant(DEMONSTRATOR_PLANT, table, count, integrator=STEPPING[adaptive],
                               initial_gauge_pa=5e3)
        for _ in range(round(hold_s / period_s)):
            plant.step(period_s, 0.0, 0.0)

    fixed, fast = (hold_s / best_and_median(lambda: shut(adaptive), repeats)[1]
                   for adaptive in (False, True))
    print(f'{"plant alone, valves shut":<28} fixed {fixed:6.1f} s/s ( 100)   adaptive '
          f'{fast:6.1f} s/s (  1.0)   x{fast / fixed:4.0f}')
    print('a hold still moves the valves on the sensor noise; the most active of the panels '
          'sets the sub-step for all')


if __name__ == '__main__':
    presets()
    tradeoff()
    step_response()
    plant_speed()
