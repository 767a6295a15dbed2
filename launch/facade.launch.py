"""Launch a whole facade through a simulated day, one process per node group.

``ros2 launch flectofold_ros facade.launch.py [facade_file:=PATH] [date:=2026-06-21]
[start:=12:00] [end:=15:00] [speedup:=360.0] [panel_processes:=2] [record_bag:=DIR]
[rerun_viewer:=auto|spawn|none|URL] [rrd_path:=day.rrd]``

The launch-time counterpart of ``ros2 run flectofold_ros facade --panel-processes N``: the
same :class:`flectofold_ros.facade.DayPlan` and the same node parameters, but every node in
its own process under ``ros2 launch``. The actions are generated, when the launch runs, from
the facade description (``facade_file``, empty for the embedded 6 x 6 demonstrator): the sun
node gets the site and UTC offset, and the panels are split over ``panel_processes``
``panel_group --group K/N`` processes of the facade's panel ids. The sun node is the clock
(mode simulated); the coordinator and the panels run on ``use_sim_time``.
"""

import os
import re
from types import SimpleNamespace

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_ros.facade import (build_plan, coordinator_parameters, panel_group_command,
                                   panel_parameters, sun_parameters)

PACKAGE = 'flectofold_ros'

#: name -> (default, description) of the launch arguments.
ARGUMENTS = {
    'facade_file': ('', 'Facade description YAML; empty: the embedded 6 x 6 demonstrator'),
    'date': ('2026-06-21', 'Local date of the simulated day (YYYY-MM-DD)'),
    'start': ('12:00', 'Local start time of the simulated day (HH:MM)'),
    'end': ('15:00', 'Local end time of the simulated day (HH:MM)'),
    'speedup': ('360.0', 'Simulated seconds per wall second, in [1, 10000]'),
    'panel_processes': ('2', 'Number of panel_group processes the panels are split over, '
                             'from 1 to the number of panels'),
    'record_bag': ('', 'Record /facade/**, /diagnostics and /clock to this bag directory '
                       '(bag_recorder); empty: no recording'),
    'rerun_viewer': ('', 'Start a rerun_bridge: auto, spawn, none (file only) or a gRPC URL; '
                         'empty: no bridge'),
    'rrd_path': ('', 'The bridge also saves this .rrd (see rerun_bridge.md)'),
}


def parameter_dict(parameters):
    """Return ``{name: value}`` of rclpy ``Parameter`` objects, as launch_ros takes them.

    Every numeric parameter of these nodes is a double: numbers become Python floats (never
    numpy scalars or ints, which would declare an integer parameter); bools and strings stay.
    """
    return {parameter.name: _plain(parameter.value) for parameter in parameters}


def _plain(value):
    if isinstance(value, (bool, str)):
        return value
    return float(value)


def _launch_error(error):
    # build_plan speaks of command-line options (--speedup, --date/--start/--end); here they
    # are the launch arguments of the same names.
    return ValueError(f'facade.launch.py: {re.sub(r"--(?=[a-z])", "", str(error))}')


def _panel_group_arguments(plan, group, groups):
    """Return the ``panel_group`` arguments of the bringup's child command, less ROS args."""
    command = panel_group_command(plan, group, groups)
    return command[command.index('--group'):command.index('--ros-args')]


def _configuration(context, name):
    return LaunchConfiguration(name).perform(context)


def launch_setup(context, *args, **kwargs):
    """Build the plan from the launch arguments and the facade; return the node actions."""
    facade_file = _configuration(context, 'facade_file').strip()
    if facade_file:
        # The node processes resolve the path themselves: make it independent of their cwd.
        facade_file = os.path.abspath(os.path.expanduser(facade_file))
    facade = load_facade(facade_file or DEFAULT_FACADE)  # FacadeError names the file
    try:
        speedup = float(_configuration(context, 'speedup'))
        groups = int(_configuration(context, 'panel_processes'))
    except ValueError as error:
        raise ValueError(f'facade.launch.py: speedup must be a number and panel_processes '
                         f'an integer: {error}') from None
    if not 1 <= groups <= len(facade):
        raise ValueError(f'facade.launch.py: panel_processes must lie in [1, {len(facade)}] '
                         f'(the panels of {facade.name}), got {groups}')
    options = SimpleNamespace(facade=facade_file, date=_configuration(context, 'date'),
                              start=_configuration(context, 'start'),
                              end=_configuration(context, 'end'), speedup=speedup,
                              panel_processes=groups)
    try:
        plan = build_plan(options, facade)
    except ValueError as error:
        raise _launch_error(error) from None
    actions = [
        Node(package=PACKAGE, executable='sun_position_node', name='sun_position',
             output='screen', parameters=[parameter_dict(sun_parameters(plan, facade))]),
        Node(package=PACKAGE, executable='coordinator_node', name='coordinator',
             namespace='/facade', output='screen',
             parameters=[parameter_dict(coordinator_parameters(plan))]),
    ]
    panel = parameter_dict(panel_parameters(plan))
    # No ``name``: a panel_group process hosts many panel nodes, and a node-name remap
    # would rename every one of them; ros2 launch labels the processes panel_group-<n>.
    actions += [Node(package=PACKAGE, executable='panel_group', output='screen',
                     arguments=_panel_group_arguments(plan, group, groups),
                     parameters=[dict(panel)])
                for group in range(groups)]
    return actions + _observers(context, facade_file)


def _observers(context, facade_file):
    """Return the recorder and the bridge, when asked for; both on the simulated clock."""
    actions = []
    bag = _configuration(context, 'record_bag').strip()
    if bag:
        actions.append(Node(package=PACKAGE, executable='bag_recorder', output='screen',
                            parameters=[{'use_sim_time': True,
                                         'output': os.path.abspath(os.path.expanduser(bag))}]))
    viewer = _configuration(context, 'rerun_viewer').strip()
    if viewer:
        rrd_path = _configuration(context, 'rrd_path').strip()
        parameters = {'use_sim_time': True, 'viewer': viewer, 'facade_file': facade_file,
                      'rrd_path': os.path.abspath(os.path.expanduser(rrd_path)) if rrd_path
                      else ''}
        actions.append(Node(package=PACKAGE, executable='rerun_bridge', namespace='/facade',
                            output='screen', parameters=[parameters]))
    return actions


def generate_launch_description():
    declared = [DeclareLaunchArgument(name, default_value=default, description=description)
                for name, (default, description) in ARGUMENTS.items()]
    return LaunchDescription(declared + [OpaqueFunction(function=launch_setup)])
