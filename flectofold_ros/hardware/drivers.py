"""The cushion drivers a panel process can run its loops on, and the loops built on one.

``simulated`` (the plant model, :class:`flectofold_model.control.SimulatedCushions`) and
``modbus`` (a Modbus TCP valve terminal, :class:`~flectofold_ros.hardware.modbus_driver.
ModbusCushions`, ``msg_docs/modbus.md``), chosen by the panel process's ``hardware``
parameter.
"""

from flectofold_model.control import compile_kernels, ControllerParameters, facade_loops
from flectofold_model.control.panel_loops import panel_indices
from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_model.kinematics.kinds import panel_kind

#: The cushion drivers there are (the ``hardware`` parameter's choices).
DRIVERS = ('simulated', 'modbus')
#: The settings :func:`build_loops` reads: the loop's, which the panels of one process share.
LOOP_SETTINGS = ('facade_file', 'hardware', 'control_period_s', 'control.time_constant_s',
                 'control.hold_band_pa', 'simulation.quiet_period_s', 'max_gauge_pressure_pa',
                 'modbus.map_file', 'modbus.host', 'modbus.port', 'modbus.timeout_s')
#: Longest one loop call works [s, wall clock]: a process that cannot keep up with its clock
#: still publishes and answers signals between calls.
MAX_CALL_S = 0.25


def build_loops(settings, panel_ids, use_sim_time, seed=0):
    """Build one process's shared loops on the driver ``settings['hardware']`` names.

    Parameters
    ----------
    settings : dict
        The values of :data:`LOOP_SETTINGS` (the panel process's parameters of those names).
    panel_ids : list of str
        The process's panels, in the order of the loops' rows.
    use_sim_time : bool
        Whether the process runs on ``/clock``; real valves refuse it.
    seed : int
        Seed of the simulated sensors' noise.

    Returns
    -------
    loops : flectofold_model.control.PanelLoops
    origins_enu_m : numpy.ndarray
        The panels' origins in the site's frame (N, 3) [m].
    facade_ids : list of str
        Every panel id of the facade.
    kind : str
        The facade's panel kind.
    """
    if settings['hardware'] not in DRIVERS:
        raise ValueError(f'hardware {settings["hardware"]!r}: no such cushion driver '
                         f'(one of {", ".join(DRIVERS)})')
    facade = load_facade(settings['facade_file'] or DEFAULT_FACADE)
    parameters = ControllerParameters(
        max_gauge_pa=settings['max_gauge_pressure_pa'],
        time_constant_s=settings['control.time_constant_s'],
        integral_time_s=4.0 * settings['control.time_constant_s'],
        hold_band_pa=settings['control.hold_band_pa'])
    if settings['hardware'] == 'modbus':
        loops = _modbus_loops(settings, use_sim_time, facade, panel_ids, parameters)
    else:
        loops = facade_loops(facade, panel_ids, settings['control_period_s'], parameters,
                             seed=seed, quiet_period_s=settings['simulation.quiet_period_s'],
                             max_call_s=MAX_CALL_S, trace=False)
    compile_kernels()  # here, before the panels report ready, not in their first tick
    origins = facade.origin_m[panel_indices(facade, panel_ids)] @ facade.facade_to_enu.T
    return loops, origins, facade.panel_ids, panel_kind(facade.panels[0])


def _modbus_loops(settings, use_sim_time, facade, panel_ids, parameters):
    """Loops on a Modbus TCP valve terminal, one map channel per panel, in ``panel_ids`` order.

    Real valves run on the wall clock: ``use_sim_time`` is refused.
    """
    from flectofold_ros.hardware.modbus_driver import ModbusCushions
    from flectofold_ros.hardware.register_map import load_register_map
    if use_sim_time:
        raise ValueError('hardware modbus drives real valves on the wall clock: '
                         'use_sim_time must be false')
    if not settings['modbus.map_file']:
        raise ValueError('hardware modbus needs modbus.map_file, the register map '
                         '(msg_docs/modbus.md)')
    register_map = load_register_map(settings['modbus.map_file'])
    if register_map.count != len(panel_ids):
        raise ValueError(f'{register_map.source} has {register_map.count} channel(s) for '
                         f'{len(panel_ids)} panel(s) ({id_span(panel_ids)})')
    driver = ModbusCushions(register_map, settings['modbus.host'], settings['modbus.port'],
                            timeout_s=settings['modbus.timeout_s'])
    return facade_loops(facade, panel_ids, settings['control_period_s'], parameters,
                        driver=driver, trace=False)


def id_span(ids):
    """Panel ids for a log line: all of up to six, else the first and the last."""
    return ', '.join(ids) if len(ids) <= 6 else f'{ids[0]} ... {ids[-1]}'
