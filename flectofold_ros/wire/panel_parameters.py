"""The parameters of a panel process: names, types, defaults, ranges (``msg_docs/panel_node.md``).

A panel process (``panel_node``, ``panel_group``) declares these on its settings node; the
loop settings (:data:`flectofold_ros.hardware.drivers.LOOP_SETTINGS`, read-only) hold for
every panel of the process, since they share one vectorised loop.
"""

from flectofold_ros.hardware.drivers import DRIVERS
from flectofold_ros.runtime.parameters import choice, double, integer, string

#: name -> Spec.
PARAMETERS = {
    'panel_id': string('', 'Panel id rNNcNN; empty: the last token of the namespace'),
    'facade_file': string('', 'Facade description YAML; empty: the embedded demonstrator'),
    'hardware': choice('simulated', 'Cushion driver', DRIVERS),
    'modbus.map_file': string('', "hardware modbus: the valve terminal's register map YAML "
                              '(msg_docs/modbus.md)'),
    'modbus.host': string('127.0.0.1', "hardware modbus: the terminal's host name or address"),
    'modbus.port': integer(502, "hardware modbus: the terminal's Modbus TCP port", 1, 65535),
    'modbus.timeout_s': double(
        0.05, 'hardware modbus: longest wait for a connection or a reply [s]; a late reply is '
        'comms_lost',
        0.001, 1.0),
    'control_period_s': double(0.1, 'Pressure loop period [s]', 0.01, 1.0),
    'control.time_constant_s': double(
        0.4, 'Closed-loop time constant [s], at least twice control_period_s', 0.02, 10.0),
    'control.hold_band_pa': double(
        60.0, 'At rest the valves stay shut within this of the target [Pa]; 3 sensor sigmas',
        0.0, 1000.0),
    'simulation.quiet_period_s': double(
        2.0, 'Simulated cushions: longest loop period while every panel of the process rests '
        '[s]', 0.01, 60.0),
    'max_gauge_pressure_pa': double(12e3, 'Hard cushion pressure limit [Pa gauge]', 2e3, 14e3),
    'publish_rate_hz': double(10.0, 'Rate of pressure, joint_states and closure [Hz]',
                              0.001, 100.0),
    'heartbeat_period_s': double(
        1.0, "At rest, the period of each panel's own state topics [s of ROS time]",
        0.01, 3600.0),
    'diagnostics_period_s': double(1.0, 'Period of /diagnostics, wall clock [s]', 0.1, 60.0),
    'setpoint_timeout_s': double(
        10.0, 'No valid setpoint for this long (ROS time) starts the safe behaviour [s]',
        0.1, 86400.0, read_only=False),
    'safe_behaviour': choice('vent', 'After a setpoint timeout: vent (open) or hold',
                             ['vent', 'hold'], read_only=False),
    'fault_action': choice('vent', 'On a latched circuit fault: vent or hold (a fill valve '
                           'stuck open always vents)', ['vent', 'hold'], read_only=False),
}
