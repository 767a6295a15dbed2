"""Many panel nodes in one process on one events executor and one vectorised loop.

``ros2 run flectofold_ros panel_group --panels r00c00,r00c01`` or ``--group 2/3`` (the third of
three equal slices of the facade's panels). The process's parameters live on its settings node
``/facade/panel_group_<K>`` (``--name``): ``--ros-args -p`` at start, ``ros2 param set`` at run
time, for every panel of the process; see ``msg_docs/panel_node.md``.
"""

import argparse
import re
import sys

from rclpy.parameter import Parameter
from rclpy.utilities import remove_ros_args

from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_ros.nodes.panel_node import run_panels
from flectofold_ros.wire import contract

#: A ROS node name: a letter or underscore, then letters, digits or underscores.
NODE_NAME = re.compile(r'[A-Za-z_][A-Za-z0-9_]*')


def group_slice(panel_ids, group, groups):
    """Return the ``group``-th of ``groups`` contiguous, nearly equal slices of ``panel_ids``."""
    if not 0 <= group < groups:
        raise ValueError(f'group {group} is not in 0..{groups - 1}')
    if groups > len(panel_ids):
        raise ValueError(f'{groups} groups for {len(panel_ids)} panels')
    start = group * len(panel_ids) // groups
    return panel_ids[start:(group + 1) * len(panel_ids) // groups]


def _group(text):
    try:
        group, groups = (int(part) for part in text.split('/'))
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected K/N, got {text!r}') from None
    return group, groups


def parse_arguments(argv):
    parser = argparse.ArgumentParser(prog='panel_group', description=__doc__.split('\n')[0])
    which = parser.add_mutually_exclusive_group(required=True)
    which.add_argument('--panels', help='comma-separated panel ids, e.g. r00c00,r00c01')
    which.add_argument('--group', type=_group, help='K/N: slice K (from 0) of N of the facade')
    parser.add_argument('--name', default='',
                        help="name of the process's settings node in /facade (default: "
                             'panel_group_K for --group K/N, panel_group_<first id> for '
                             '--panels)')
    parser.add_argument('--facade', default='',
                        help='facade YAML (default: the embedded demonstrator); sets the '
                             "nodes' facade_file parameter")
    options = parser.parse_args(argv)
    if options.panels is not None and not _ids(options.panels):
        parser.error(f'--panels names no panel: {options.panels!r}')
    for panel_id in _ids(options.panels or ''):
        if not contract.PANEL_ID.fullmatch(panel_id):
            parser.error(f'--panels: {panel_id!r} is no panel id (r<row>c<column>, two '
                         f'digits each)')
    if options.name and not NODE_NAME.fullmatch(options.name):
        parser.error(f'--name must be a ROS node name (a letter or _, then letters, digits '
                     f'or _), got {options.name!r}')
    return options


def _ids(text):
    return [p.strip() for p in text.split(',') if p.strip()]


def main(args=None):
    argv = remove_ros_args(args=sys.argv if args is None else args)[1:]
    options = parse_arguments(argv)
    overrides = [Parameter('facade_file', value=options.facade)] if options.facade else []

    def panel_ids():
        if options.panels is not None:
            return _ids(options.panels)
        facade = load_facade(options.facade or DEFAULT_FACADE)
        return group_slice(facade.panel_ids, *options.group)

    name = options.name or (f'panel_group_{options.group[0]}' if options.group
                            else f'panel_group_{_ids(options.panels)[0]}')
    return run_panels('panel_group', args, panel_ids, group_name=name,
                      parameter_overrides=overrides)


if __name__ == '__main__':
    sys.exit(main())
