"""Entry points of the package's executables: stop signals handled from the first instant.

A console script imports its module before it runs anything, and importing rclpy, numpy,
scipy and pvlib takes a second or two: a Ctrl-C then would print a ``KeyboardInterrupt``
traceback from deep in an import. Each entry point here installs the package's stop-signal
handling (:mod:`flectofold_ros.runtime.runner`) first, with nothing but the standard library
loaded, then imports the executable's module and runs its ``main``. ``python -m flectofold_ros NAME
ARGS`` does the same; the ``facade`` bringup starts its children that way.
"""

import importlib
import os
import sys

from flectofold_ros.runtime.runner import die_with_parent, Interrupted, stop_signals

#: Executable -> (module with ``main(args=None)``, exit code when stopped while it loads):
#: a node asked to stop ends normally (0), a day or a command cut short says so (130).
#: The one list of the package's executables: each is the console script ``NAME`` running
#: :func:`run` through this module's function ``NAME``; ``setup.py`` reads this literal from
#: the source (it does not import the package) to list them, so it stays a plain literal.
EXECUTABLES = {
    'fold_table': ('flectofold_ros.commands.fold_table', 130),
    'day_report': ('flectofold_ros.commands.day_report', 130),
    'annual_report': ('flectofold_ros.commands.annual_report', 130),
    'building_report': ('flectofold_ros.commands.building_report', 130),
    'panel_node': ('flectofold_ros.nodes.panel_node', 0),
    'panel_group': ('flectofold_ros.nodes.panel_group', 0),
    'sun_position_node': ('flectofold_ros.nodes.sun_position', 0),
    'weather_node': ('flectofold_ros.nodes.weather', 0),
    'coordinator_node': ('flectofold_ros.nodes.coordinator', 0),
    'facade': ('flectofold_ros.bringup.cli', 130),
    'rerun_bridge': ('flectofold_ros.nodes.rerun_bridge', 0),
    'facade_markers': ('flectofold_ros.nodes.facade_markers', 0),
    'bag_recorder': ('flectofold_ros.nodes.bag_recorder', 0),
    'replay': ('flectofold_ros.commands.replay', 0),
    'bag_reindex': ('flectofold_ros.commands.bag_reindex', 130),
    'facade_export': ('flectofold_ros.commands.facade_export', 130),
    'valve_terminal_sim': ('flectofold_ros.commands.valve_terminal_sim', 0),
    'bacnet_gateway': ('flectofold_ros.nodes.bacnet_gateway', 0),
    'structure_cache': ('flectofold_ros.commands.structure_cache', 130),
    'site_certificates': ('flectofold_ros.commands.site_certificates', 130),
}


#: Executables that leave at once when their ``main`` returns, without the interpreter's
#: teardown (unloading the compiled kernels' LLVM code and the DDS libraries; its cost:
#: ``msg_docs/panel_node.md``). Their valves are shut by then and the standard streams are
#: flushed; their DDS entities go with the process (``PanelProgram``).
FAST_EXIT = frozenset({'panel_node', 'panel_group'})


def exit_with(name, code):
    """End the process with ``code`` after executable ``name`` ran (see :data:`FAST_EXIT`)."""
    if name in FAST_EXIT:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code if isinstance(code, int) else 1)
    sys.exit(code)


def run(name, args=None, ending=False):
    """Run executable ``name`` with ``args`` (``sys.argv`` when None); return its exit code.

    ``ending``: the process ends when this returns (a console script, ``python -m``), so the
    stop signals stay ignored from the end of ``main`` to the exit
    (:meth:`~flectofold_ros.runtime.runner.StopSignals.leaving`); a caller that goes on gets its
    handlers back.
    """
    module_name, stopped_code = EXECUTABLES[name]
    with stop_signals() as stop:
        try:
            die_with_parent()
            return importlib.import_module(module_name).main(args)
        except Interrupted:
            return stopped_code
        except BrokenPipeError:
            # the reader of the output left (``day_report | head``): no traceback, and none
            # at exit from flushing into the closed pipe either (the Python docs' recipe)
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return 1
        except (ImportError, RuntimeError) as error:
            # A stop signal that lands in an extension module's initialisation comes out as
            # "ImportError: initialization failed", one in a class body's __set_name__ (a
            # dataclass field while scipy imports) as a RuntimeError raised from it: the
            # start was abandoned all the same.
            if stop.requested and (isinstance(error, ImportError) or _from_interrupt(error)):
                return stopped_code
            raise
        finally:
            if ending:
                stop.leaving()


def _from_interrupt(error):
    """Whether ``error`` was raised from an :class:`Interrupted` (its cause or context)."""
    seen = set()
    while error is not None and id(error) not in seen:
        if isinstance(error, Interrupted):
            return True
        seen.add(id(error))
        error = error.__cause__ or error.__context__
    return False


def _entry_point(name):
    def main():
        exit_with(name, run(name, ending=True))
    main.__name__ = name
    main.__doc__ = f'Console script ``{name}``.'
    return main


# The console scripts' entry points: ``fold_table = _entry_point('fold_table')`` and so on.
globals().update({name: _entry_point(name) for name in EXECUTABLES})
