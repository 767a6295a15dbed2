"""Launch a whole facade through a simulated day, one process per node group.

``ros2 launch flectofold_ros facade.launch.py [facade_file:=PATH] [date:=2026-06-21]
[start:=12:00] [end:=15:00] [speedup:=360.0] [panel_processes:=2] [record_bag:=DIR]
[rerun_viewer:=auto|spawn|none|URL] [rrd_path:=day.rrd] [weather_file:=PATH]
[markers:=true] [site_profile:=XML]``

The launch-time counterpart of ``ros2 run flectofold_ros facade --panel-processes N``: the
same :class:`flectofold_ros.bringup.plan.DayPlan` and so the same node parameters, but every
node in its own process under ``ros2 launch``. The actions are generated, when the launch
runs, from the facade description (``facade_file``, empty for the embedded 6 x 6
demonstrator): the sun node gets the site, and the panels are split over ``panel_processes``
``panel_group --group K/N`` processes of the facade's panel ids. The sun node is the clock
(mode simulated); the coordinator and the panels run on ``use_sim_time``. The sun node holds
the clock at the start until every panel reports and the coordinator and the observers
listen (its ``start.*`` parameters), as the ``facade`` command holds it.

The coordinator and the panel processes are respawned when they die (``RESPAWN``: after 2 s,
at most 5 times), as the ``facade`` command restarts them; a respawned panel process starts
its panels vented and takes the coordinator's next setpoint. The sun node is not: it is the
clock, and a new one would start the day again. Nor are the observers: a new recorder would
refuse the existing bag directory, a new bridge overwrite the ``.rrd``.

``site_profile``: every node process runs on this Fast DDS profile (``site_certificates``
makes one per host: TCP with mutual TLS on the site network), checked before any starts, as
``facade --site-profile`` does: node K in the order of the actions listens on the profile's
port plus K and dials the others (``msg_docs/security.md``). Empty (the default): ROS's
loopback-only discovery.
"""

import os
import tempfile

from launch import LaunchDescription
from launch.actions import (DeclareLaunchArgument, OpaqueFunction, SetEnvironmentVariable,
                            UnsetEnvironmentVariable)
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_ros.bringup.plan import plan_day, PlanError
from flectofold_ros.sitenet.certificates import SiteError
from flectofold_ros.sitenet.fastdds_profile import process_profile, site_environment, SITE_REMOVED
from flectofold_ros.wire import contract

PACKAGE = 'flectofold_ros'
#: How launch restarts a node process that died (the facade command backs off instead).
RESPAWN = {'respawn': True, 'respawn_delay': 2.0, 'respawn_max_retries': 5}
#: The variables that name a Fast DDS profile file (2.x, 3.x).
PROFILE_VARIABLES = ('FASTRTPS_DEFAULT_PROFILES_FILE', 'FASTDDS_DEFAULT_PROFILES_FILE')

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
    'weather_file': ('', 'Play this EPW or TMY3 file into the coordinator (weather_node, '
                         'weather.md); empty: no weather'),
    'markers': ('false', 'true: start facade_markers, the folded facade on /facade/markers for '
                         'RViz and Foxglove (markers.md)'),
    'site_profile': ('', 'Run every node process on this Fast DDS profile (site_certificates '
                         'makes one per host: TCP with mutual TLS; security.md); empty: '
                         "ROS's loopback-only discovery"),
}


def _configuration(context, name):
    return LaunchConfiguration(name).perform(context).strip()


def _absolute(path):
    """Return a path the node processes resolve alike whatever their working directory."""
    return os.path.abspath(os.path.expanduser(path)) if path else ''


def launch_setup(context, *args, **kwargs):
    """Plan the day from the launch arguments and the facade; return the node actions."""
    facade_file = _absolute(_configuration(context, 'facade_file'))
    facade = load_facade(facade_file or DEFAULT_FACADE)  # FacadeError names the file
    try:
        plan = plan_day(facade, facade_file, *(_configuration(context, name) for name in
                                               ('date', 'start', 'end', 'speedup',
                                                'panel_processes')),
                        least_processes=1)
    except PlanError as error:
        raise PlanError(f'facade.launch.py: {error}') from None
    observers = _observers(context, plan)
    # The day starts when every panel reports and the coordinator and the observers listen
    # to the sun, as the facade command starts it: else a sped-up day runs ahead of them.
    sun = plan.sun_parameters(wait_for_panels=len(facade),
                              wait_for_sun_listeners=1 + len(observers))
    actions = [
        Node(package=PACKAGE, executable='sun_position_node', name=contract.SUN_POSITION_NODE,
             output='screen', parameters=[sun]),
        Node(package=PACKAGE, executable='coordinator_node', name=contract.COORDINATOR_NODE,
             namespace=contract.FACADE_NODE_NAMESPACE, output='screen',
             parameters=[plan.coordinator_parameters()], **RESPAWN),
    ]
    # No ``name``: a panel_group process hosts many panel nodes, and a node-name remap
    # would rename every one of them; ros2 launch labels the processes panel_group-<n>.
    actions += [Node(package=PACKAGE, executable='panel_group', output='screen',
                     arguments=plan.panel_group_arguments(group),
                     parameters=[plan.panel_parameters()], **RESPAWN)
                for group in range(plan.panel_processes)]
    weather_file = _absolute(_configuration(context, 'weather_file'))
    if weather_file:
        actions.append(Node(package=PACKAGE, executable='weather_node',
                            name=contract.WEATHER_NODE, output='screen',
                            parameters=[plan.weather_parameters(weather_file)], **RESPAWN))
    return _on_site_profile(context, actions + observers, actions[2:2 + plan.panel_processes])


def _on_site_profile(context, nodes, panel_processes):
    """Put every node process on the site profile, each with its own port, when one is given.

    Node ``k`` (in the order of ``nodes``) takes the profile's port P + k and dials the
    others (:func:`~flectofold_ros.sitenet.fastdds_profile.process_profile`); its profile is
    set in the environment right before its action, which takes the environment as it is.
    """
    path = _absolute(_configuration(context, 'site_profile'))
    if not path:
        return nodes
    try:
        env = site_environment(path, {})
        directory = tempfile.mkdtemp(prefix='flectofold_site_')
        profiles = []
        for index in range(len(nodes)):
            profiles.append(os.path.join(directory, f'process_{index}.xml'))
            with open(profiles[-1], 'w') as handle:
                handle.write(process_profile(
                    path, index, len(nodes),
                    panel_process=nodes[index] in panel_processes))
    except SiteError as error:
        raise PlanError(f'facade.launch.py: site_profile: {error}') from None
    actions = [SetEnvironmentVariable(name, value) for name, value in env.items()]
    actions += [UnsetEnvironmentVariable(name) for name in SITE_REMOVED]
    for node, profile in zip(nodes, profiles):
        actions += [SetEnvironmentVariable(name, profile) for name in PROFILE_VARIABLES]
        actions.append(node)
    return actions


def _observers(context, plan):
    """Return the recorder, the markers and the bridge, when asked for; on the simulated clock."""
    actions = []
    bag = _configuration(context, 'record_bag')
    if bag:
        actions.append(Node(package=PACKAGE, executable='bag_recorder', output='screen',
                            parameters=[plan.recorder_parameters(_absolute(bag))]))
    markers = _configuration(context, 'markers').lower()
    if markers not in ('true', 'false'):
        raise PlanError(f'facade.launch.py: markers must be true or false, got {markers!r}')
    if markers == 'true':
        actions.append(Node(package=PACKAGE, executable='facade_markers',
                            namespace=contract.FACADE_NODE_NAMESPACE, output='screen',
                            parameters=[plan.markers_parameters()]))
    viewer = _configuration(context, 'rerun_viewer')
    if viewer:
        rrd_path = _absolute(_configuration(context, 'rrd_path'))
        actions.append(Node(package=PACKAGE, executable='rerun_bridge',
                            namespace=contract.FACADE_NODE_NAMESPACE, output='screen',
                            parameters=[plan.bridge_parameters(rrd_path, viewer)]))
    return actions


def generate_launch_description():
    declared = [DeclareLaunchArgument(name, default_value=default, description=description)
                for name, (default, description) in ARGUMENTS.items()]
    return LaunchDescription(declared + [OpaqueFunction(function=launch_setup)])
