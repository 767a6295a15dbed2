"""Spinning an executor of many nodes until done, so that Ctrl-C and SIGTERM always get through.

``rclpy.experimental.EventsExecutor`` of the Jazzy wheels (rclpy 7.1.6) does not return from
``spin()`` or ``spin_until_future_complete()`` here: its timers stop firing and it keeps the
GIL. ``spin_once`` handles one event per call and works, so every executable of the package
spins through :func:`spin_until`.
"""

import sys

import rclpy
from rclpy.experimental import EventsExecutor
from rclpy.utilities import remove_ros_args


def make_executor():
    """Return the executor that scales to hundreds of nodes in one process."""
    return EventsExecutor()


def spin_until(executor, done=lambda: False, context=None):
    """Handle events until ``done()`` or the context shuts down (a signal, say)."""
    while rclpy.ok(context=context) and not done():
        try:
            executor.spin_once(timeout_sec=0.1)
        except RuntimeError:
            # A signal that shuts the context down mid-call can surface as a pybind error.
            if rclpy.ok(context=context):
                raise
            return


def print_usage_if_asked(args, usage, parameters):
    """Answer ``--help``/``-h`` (outside ``--ros-args``) with usage and parameters; return it.

    ``parameters`` maps names to ``(default, ParameterDescriptor)``.
    """
    argv = remove_ros_args(args=sys.argv if args is None else args)[1:]
    if not {'-h', '--help'} & set(argv):
        return False
    print(f'usage: {usage}\n\nparameters (--ros-args -p name:=value):')
    for name, (default, descriptor) in parameters.items():
        ranges = [f'[{r.from_value:g}, {r.to_value:g}]'
                  for r in descriptor.floating_point_range]
        extra = ' '.join(ranges + [descriptor.additional_constraints]).strip()
        print(f'  {name} (default {default!r}{", " + extra if extra else ""}'
              f'{", read-only" if descriptor.read_only else ""}): {descriptor.description}')
    return True
