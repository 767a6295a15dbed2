"""The panel process's start: its nodes on one shared loop; the ``panel_node`` executable.

:func:`start_panels` creates one process's panel nodes (:mod:`flectofold_ros.nodes.panel`)
on one loop built on its cushion driver; :func:`run_panels` runs them until a stop signal,
the body of ``panel_node`` (one panel, here) and ``panel_group`` (many,
:mod:`flectofold_ros.nodes.panel_group`). ``msg_docs/panel_node.md``.
"""

import os
from pathlib import Path
import sys

from rclpy.node import Node

from flectofold_ros.hardware.drivers import build_loops, id_span, LOOP_SETTINGS
from flectofold_ros.nodes.panel import PanelNode, PanelProcess
from flectofold_ros.runtime.domain_watch import Presence, StartCheck
from flectofold_ros.runtime.parameters import declare_all
from flectofold_ros.runtime.runner import Program, run_nodes
from flectofold_ros.wire import contract, presence
from flectofold_ros.wire.panel_parameters import PARAMETERS

#: The Fast DDS profile a panel process uses unless the user gives one (see the file).
FASTDDS_PROFILE = Path(__file__).resolve().parent.parent / 'fastdds_panel_process.xml'
PROFILE_VARIABLES = ('FASTRTPS_DEFAULT_PROFILES_FILE', 'FASTDDS_DEFAULT_PROFILES_FILE')
USAGE = 'panel_node --ros-args -r __ns:=/facade/<id> [-p name:=value ...]'


class PanelProgram(Program):
    """A panel process as a program: on close, the valves shut.

    As an executable (``panel_node``, ``panel_group``) it ends its process right after, without
    tearing down its DDS entities one by one (:attr:`Program.teardown`; the process's end
    frees them, and its peers drop its participant when its lease runs out; why:
    ``msg_docs/panel_node.md``, "The loop and the hardware interface").
    """

    def __init__(self, nodes, process, teardown=True):
        self.teardown = teardown
        super().__init__(nodes)
        self.process = process

    def close(self, interrupted):
        self.process.close()


def start_panels(panel_ids=None, group_name=None, seed=0, teardown=True, **node_kwargs):
    """Create the panel nodes of one process on one shared loop; return the :class:`Program`.

    ``group_name`` None: one :class:`PanelNode` (its id from ``panel_ids[0]``, its namespace
    or ``panel_id``) that also holds the parameters. Otherwise a settings node
    ``/facade/<group_name>`` holds them for one light node per id of ``panel_ids``.
    """
    nodes = []
    try:
        if group_name is None:
            nodes.append(PanelNode((panel_ids or [None])[0], **node_kwargs))
            settings, panels = nodes[0], nodes
        else:
            nodes.append(Node(group_name, namespace=contract.FACADE_NODE_NAMESPACE,
                              **node_kwargs))
            declare_all(nodes[0], PARAMETERS)
            context = {'context': node_kwargs['context']} if 'context' in node_kwargs else {}
            for panel_id in panel_ids:
                nodes.append(PanelNode(panel_id, settings=False, **context))
            settings, panels = nodes[0], nodes[1:]
        ids = [panel.panel_id for panel in panels]
        if len(set(ids)) != len(ids):
            raise ValueError(f'a panel is named twice in {", ".join(ids)}')
        # listening while the loops are built
        check = StartCheck(f'{settings.get_name()}_start_check', settings.context)
        loops, origins, facade_ids, kind = build_loops(
            {name: settings.get_parameter(name).value for name in LOOP_SETTINGS}, ids,
            settings.get_parameter('use_sim_time').value, seed=seed)
        own = presence.this_process(
            presence.PANELS, settings.get_parameter('facade_file').value or 'demonstrator',
            [settings.get_fully_qualified_name()], ids)
        check.refuse(own)
        process = PanelProcess(settings, panels, loops, origins, facade_ids, kind)
        process.presence = Presence(settings, own)
        process.presence.announce()
    except BaseException:
        for node in nodes:
            node.destroy_node()
        raise
    settings.get_logger().info(f'{len(panels)} panel(s) ready: {id_span(ids)}')
    return PanelProgram(nodes, process, teardown)


def use_panel_process_profile(environ=os.environ):
    """Give Fast DDS the panel process's profile, unless the user chose a profile or an RMW.

    Called before rclpy starts; see ``fastdds_panel_process.xml``.
    """
    if any(environ.get(name) for name in PROFILE_VARIABLES):
        return
    if environ.get('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp') != 'rmw_fastrtps_cpp':
        return
    environ['FASTRTPS_DEFAULT_PROFILES_FILE'] = str(FASTDDS_PROFILE)


def run_panels(name, args, panel_ids=lambda: None, group_name=None, usage=None,
               **node_kwargs):
    """Run a panel process until a stop signal: the body of ``panel_node`` and ``panel_group``.

    ``panel_ids()`` gives the ids (None: one node, its id from its namespace).
    """
    use_panel_process_profile()
    return run_nodes(name, args,
                     lambda: start_panels(panel_ids(), group_name, teardown=False,
                                          **node_kwargs),
                     usage, PARAMETERS)


def main(args=None):
    """``ros2 run flectofold_ros panel_node --ros-args -r __ns:=/facade/r00c00``."""
    return run_panels('panel_node', args, usage=USAGE)


if __name__ == '__main__':
    sys.exit(main())
