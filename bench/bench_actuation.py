"""Actuation figures: the presets, the fold-radius trade-off table and the pressure-loop step.

Run with ``.venv/bin/python bench/bench_actuation.py``. Everything printed is computed here,
from flectofold_model; nothing is copied from elsewhere.
"""

import math

import numpy as np

from flectofold_model.actuation import (ActuationModel, CushionMap, DEMONSTRATOR_ACTUATED,
                                        FLECTOLINE_ACTUATED, radius_study)
from flectofold_model.loop_simulation import simulate, step_metrics
from flectofold_model.pneumatics import (DEMONSTRATOR_PLANT, physical_fill_time_s,
                                         PneumaticPlant)
from flectofold_model.pressure_control import PressureController


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


if __name__ == '__main__':
    presets()
    tradeoff()
    step_response()
