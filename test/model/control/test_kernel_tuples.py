"""The compiled kernels read their tuples by field name, and the packed tuples fill the fields.

Every tuple the loop and engine kernels take has a ``NamedTuple`` of its fields; kernel code
reads them by name only, never by an index (a number or a named constant) or by unpacking them
in order. Python passes them as plain tuples in the fields' order, some packed where the names
are not known (:meth:`.CushionMap.compiled_tables`, :meth:`.PneumaticPlant.kernel_view`): each
packed tuple is held here to the quantity each field names.
"""

import ast
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
import pytest

from flectofold_model.actuation import (ActuationModel, ATMOSPHERIC_PRESSURE_PA, CushionMap,
                                        DEMONSTRATOR_ACTUATED, DEMONSTRATOR_PLANT,
                                        PneumaticPlant)
from flectofold_model.actuation import integration
from flectofold_model.control import loop_kernel, simulation_kernel
from flectofold_model.control.pressure_loop import ControllerParameters, PressureController

COUNT = 3
#: Names the kernels give their tuple arguments and locals.
TUPLE_NAMES = {'parameters', 'circuit', 'tables', 'plant', 'engine', 'sensors', 'panel'}
KERNEL_MODULES = (loop_kernel, simulation_kernel, integration)


def cushion_map():
    return CushionMap(ActuationModel([DEMONSTRATOR_ACTUATED] * COUNT))


def test_no_kernel_reads_a_tuple_by_position():
    found = []
    for module in KERNEL_MODULES:
        path = Path(module.__file__)
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Subscript) and _tuple_name(node.value):
                found.append(f'{path.name}:{node.lineno} {ast.unparse(node)}')
            if isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Tuple) and \
                    _tuple_name(node.value):
                found.append(f'{path.name}:{node.lineno} {ast.unparse(node)}')
    assert not found, f'read these by field name: {found}'


def _tuple_name(node):
    if isinstance(node, ast.Attribute):
        return node.attr in TUPLE_NAMES
    return isinstance(node, ast.Name) and node.id in TUPLE_NAMES


def test_the_loop_parameters_are_the_controller_parameters_field_by_field():
    parameters = ControllerParameters(hold_band_pa=60.0, leak_error_pa=250.0, stuck_time_s=0.7)
    named = loop_kernel.LoopParameters(*loop_kernel.parameter_tuple(parameters))
    assert named._asdict() == asdict(parameters)


def test_the_loop_circuit_and_tables_name_the_plant_and_the_map():
    tables_source = cushion_map()
    controller = PressureController(tables_source, DEMONSTRATOR_PLANT)
    circuit = loop_kernel.LoopCircuit(*controller.kernel_circuit)
    assert circuit.fill_conductance_m3_s_pa == DEMONSTRATOR_PLANT.fill_conductance_m3_s_pa
    assert circuit.vent_conductance_m3_s_pa == DEMONSTRATOR_PLANT.vent_conductance_m3_s_pa
    assert circuit.critical_ratio == DEMONSTRATOR_PLANT.critical_ratio
    assert circuit.dead_volume_m3 == DEMONSTRATOR_PLANT.dead_volume_m3
    tables = loop_kernel.MapTables(*controller.kernel_tables)
    row = tables.row
    np.testing.assert_array_equal(row, tables_source.row)
    np.testing.assert_array_equal(tables.pressure_pa[row], tables_source.pressure_pa)
    np.testing.assert_array_equal(tables.volume_m3[row], tables_source.volume_m3)
    np.testing.assert_array_equal(tables.compliance_m3_per_pa[row],
                                  tables_source.compliance_m3_per_pa)
    np.testing.assert_array_equal(tables.fold_angle_rad[row], tables_source.fold_angle_rad)
    np.testing.assert_array_equal(tables.closures, tables_source.closures)


def test_the_engine_tuples_name_the_plant_its_faults_and_its_sensors():
    tables_source = cushion_map()
    circuit_parameters = replace(DEMONSTRATOR_PLANT, sensor_offset_pa=5.0, sensor_noise_pa=7.0)
    plant = PneumaticPlant(circuit_parameters, tables_source, COUNT, seed=1,
                           integrator='embedded')
    plant.inject_leak([1], 1e-9)
    plant.inject_fill_valve_stuck_open([2])
    plant.inject_supply_loss([0])
    plant.inject_sensor_stuck([0])
    plant.inject_sensor_dropout([1])
    plant.inject_sensor_noise([2], 30.0)
    plant.step(0.5, np.array([1.0, 0.0, 0.0]), np.zeros(COUNT))
    arrays, constants, sensors = plant.kernel_view()

    arrays = simulation_kernel.PlantArrays(*arrays)
    np.testing.assert_array_equal(arrays.pressure_pa - ATMOSPHERIC_PRESSURE_PA,
                                  plant.gauge_pressure_pa)
    assert arrays.lagged_pa is plant.sensors.lagged_pa
    assert arrays.leak_conductance_m3_s_pa is plant.faults.leak_conductance
    leak = arrays.leak_conductance_m3_s_pa
    assert leak[1] - leak[0] == pytest.approx(1e-9)
    np.testing.assert_array_equal(arrays.fill_stuck, [False, False, True])
    np.testing.assert_array_equal(arrays.supply_pa, plant.supply_pressure_pa)
    assert arrays.supply_pa[0] == ATMOSPHERIC_PRESSURE_PA < arrays.supply_pa[1]
    assert np.all(arrays.step_s > 0.0)

    constants = simulation_kernel.EngineConstants(*constants)
    assert constants.fill_conductance_m3_s_pa == circuit_parameters.fill_conductance_m3_s_pa
    assert constants.vent_conductance_m3_s_pa == circuit_parameters.vent_conductance_m3_s_pa
    assert constants.sensor_lag_s == circuit_parameters.sensor_lag_s
    assert constants.tolerance_pa == integration.TOLERANCE_PA
    tables = integration.CushionTables(*constants.tables)
    row = constants.row
    np.testing.assert_array_equal(tables.pressure_pa[row], tables_source.pressure_pa)
    np.testing.assert_array_equal(tables.volume_m3[row], tables_source.volume_m3)
    np.testing.assert_array_equal(tables.compliance_m3_per_pa[row],
                                  tables_source.compliance_m3_per_pa)
    circuit = integration.EngineCircuit(*constants.circuit)
    assert circuit.critical_ratio == circuit_parameters.critical_ratio
    assert circuit.dead_volume_m3 == circuit_parameters.dead_volume_m3
    assert circuit.relief_cracking_pa == circuit_parameters.relief_cracking_pa
    assert circuit.relief_span_pa == (circuit_parameters.relief_full_open_pa
                                      - circuit_parameters.relief_cracking_pa)
    assert circuit.relief_conductance_m3_s_pa == circuit_parameters.relief_conductance_m3_s_pa

    sensors = simulation_kernel.SensorView(*sensors)
    assert sensors.offset_pa == 5.0
    assert sensors.supply_noise_pa == 7.0
    np.testing.assert_array_equal(sensors.noise_pa, [7.0, 7.0, 30.0])
    np.testing.assert_array_equal(sensors.stuck, [True, False, False])
    np.testing.assert_array_equal(sensors.dropout, [False, True, False])
    assert sensors.last_reading_pa.shape == (COUNT,)
