"""The one way every executable of the package runs: start, spin, stop on a signal, close.

Policy, the same for every executable:

* **Bad input at start** (a parameter out of range or of the wrong type, an unknown panel, a
  facade description or a path that cannot be used): one line ``<executable>: <reason>`` on
  stderr, exit code 2, no traceback.
* **SIGINT or SIGTERM, at any moment.** A terminal's Ctrl-C reaches every process of its group
  at once; a service manager sends SIGTERM (then SIGKILL). While the program is starting, the
  signal abandons the start; once it runs, the spin ends at the next event (within 0.1 s) and
  the program closes. Either way the exit is clean: no traceback, no ``[FATAL]`` line. While
  it closes (a recorder finishing its bag, a bringup waiting for its children) further
  signals are ignored, so a second Ctrl-C, or the same one forwarded by a parent, cannot cut
  the close short; they stay ignored once the work is done, through the interpreter's exit.
  SIGKILL remains the way to stop a process at once.
* Exit code 0 when a node's work is done or it was asked to stop; a program may choose
  another (the bringup exits 130 when its day was interrupted).

rclpy's own signal handlers are not installed (``SignalHandlerOptions.NO``): they raise
``KeyboardInterrupt`` at any bytecode, also in the middle of a close. The executor spins
with :meth:`spin_once` in a loop, since ``EventsExecutor.spin()`` of the Jazzy wheels does
not return.

rclpy is imported only by :func:`run_nodes`, so the commands that need no ROS graph (the
offline ``replay --to-rrd``, ``fold_table``, ``day_report``) run without it.
"""

from contextlib import contextmanager
import ctypes
import os
import signal
import sys

#: Seconds the executor waits for an event before the loop looks at the stop signals again.
SPIN_PERIOD_S = 0.1
#: Exit code of a program that stopped because its disk has no room (a recorder): started
#: again onto the same disk it would stop again, so the bringup does not restart it.
NO_ROOM = 4
#: Environment variable by which a supervising process (the ``facade`` bringup) asks a child
#: to die with it: the supervisor's process id.
PARENT_ENVIRONMENT = 'FLECTOFOLD_DIE_WITH_PARENT'
#: ``prctl`` option of Linux: the signal the kernel sends when the parent dies.
_PR_SET_PDEATHSIG = 1


def die_with_parent(environ=os.environ):
    """Have SIGTERM sent to this process when its supervisor dies, even by SIGKILL.

    Does something only when ``environ`` names the supervisor (:data:`PARENT_ENVIRONMENT`),
    which it then forgets, so that the process's own children do not inherit it. Linux's
    ``PR_SET_PDEATHSIG``: the kernel signals when the thread that started the process ends
    (the bringup starts and restarts its children on its main thread). A supervisor that died
    before the request was made is no longer the parent: the process then stops at once. The
    SIGTERM is a stop request as any other (:class:`StopSignals`): a panel process shuts its
    valves, a recorder closes its bag. Return whether the request was made (False elsewhere
    than Linux, or with no supervisor named).
    """
    supervisor = environ.pop(PARENT_ENVIRONMENT, None)
    if not supervisor or not sys.platform.startswith('linux'):
        return False
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0) != 0:
        return False
    if str(os.getppid()) != supervisor:  # it died between our start and the request
        os.kill(os.getpid(), signal.SIGTERM)
    return True


class Interrupted(BaseException):
    """A stop signal arrived while the program was starting.

    A ``BaseException``, like ``KeyboardInterrupt``, so that no ``except Exception`` on the
    way swallows it.
    """


class StopSignals:
    """SIGINT and SIGTERM turned into a stop request (a context manager).

    Starting: a signal raises :class:`Interrupted`, once; signals while the abandoned start
    unwinds are counted. Running: it sets :attr:`requested`. Closing: it is counted and
    ignored.
    """

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self):
        self.received = []
        self._phase = 'starting'
        self._previous = {}
        self._restore = True

    def __enter__(self):
        self._previous_unraisable_hook = sys.unraisablehook
        sys.unraisablehook = self._unraisable
        # A signal the parent ignores stays ignored (a shell's background job ignores SIGINT,
        # as does a process under nohup), as Python itself does for SIGINT.
        self._previous = {number: signal.signal(number, self._handle) for number in self.SIGNALS
                          if signal.getsignal(number) is not signal.SIG_IGN}
        return self

    def __exit__(self, *exception):
        for number, handler in self._previous.items():
            signal.signal(number, handler if self._restore else signal.SIG_IGN)
        sys.unraisablehook = self._previous_unraisable_hook
        return False

    def _unraisable(self, unraisable):
        # A signal that lands in a weakref callback or a __del__ (the import system runs
        # some) cannot abandon the start from there: Python reports and drops the raise. The
        # signal is still recorded, so the program stops as soon as it runs, and the start
        # goes on, so a later signal may still abandon it.
        if not isinstance(unraisable.exc_value, Interrupted):
            self._previous_unraisable_hook(unraisable)
        elif self._phase == 'abandoning':
            self._phase = 'starting'

    def _handle(self, number, frame):
        self.received.append(number)
        if self._phase == 'starting':
            # One raise abandons the start. A second signal while it unwinds (a bringup's
            # SIGTERM after the terminal's SIGINT to the group) is only recorded: raised again,
            # it would cut the unwinding short with a traceback.
            self._phase = 'abandoning'
            raise Interrupted(signal.Signals(number).name)

    @property
    def requested(self):
        """Whether a stop signal arrived."""
        return bool(self.received)

    def running(self):
        """Mark the program running: from now on a signal only asks it to stop."""
        self._phase = 'running'

    def closing(self):
        """Mark the program closing: from now on signals are ignored."""
        self._phase = 'closing'

    def leaving(self):
        """Mark the process ending: signals stay ignored after the context, to the exit.

        Without it, a signal in the second or so between the end of ``main`` and the end of
        the process (the interpreter unloading its modules) meets the default disposition,
        restored by Python's own teardown, and kills the process with -SIGINT after its work
        was done and reported.
        """
        self._phase = 'closing'
        self._restore = False


_installed = None


@contextmanager
def stop_signals():
    """Yield the process's :class:`StopSignals`: installed here, or the one installed."""
    global _installed
    if _installed is not None:
        yield _installed
        return
    with StopSignals() as stop:
        _installed = stop
        try:
            yield stop
        finally:
            _installed = None


def stop_requested():
    """Whether the running program was asked to stop (a signal arrived)."""
    return _installed is not None and _installed.requested


class Program:
    """What an executable runs: its nodes, when it is done and how it closes.

    The base class runs its nodes until a stop signal; subclasses override :meth:`done`
    (end by themselves) and :meth:`close` (flush files, print a summary, choose the exit code).
    """

    #: Destroy the nodes and shut ROS down after :meth:`close`. A program that ends its
    #: process at once after (``executables.FAST_EXIT``) may skip it: with thousands of
    #: endpoints, destroying them one by one takes minutes (Fast DDS looks through every
    #: endpoint for each one it deletes), and the process's end frees them all.
    teardown = True

    def __init__(self, nodes=()):
        self.nodes = list(nodes)

    def done(self):
        """Whether the program has finished its work (checked after every event)."""
        return False

    def close(self, interrupted):
        """Finish before the nodes are destroyed; return the exit code (None: the default)."""
        return None


def configure_or_destroy(node, configure):
    """Run ``configure()`` for a node being built; on any error destroy the node, re-raise.

    A node refused at start (a bad parameter, an unreadable file) would otherwise keep its
    DDS entities and its name on the graph until the process ends.
    """
    try:
        configure()
    except Exception:
        node.destroy_node()
        raise


def run_command(name, body, bad_input=(), interrupted_code=0):
    """Run ``body(stop_signals)`` -> exit code under the policy above, without ROS.

    ``bad_input`` adds exception types that mean bad input (``ValueError`` always does).
    """
    with stop_signals() as stop:
        try:
            code = body(stop)
        except Interrupted:
            return interrupted_code
        except (ValueError, *bad_input) as error:
            print(f'{name}: {error}', file=sys.stderr, flush=True)
            return 2
    return interrupted_code if stop.requested and code is None else (code or 0)


def run_nodes(name, args, start, usage=None, parameters=None, bad_input=(), interrupted_code=0):
    """Start ``start()`` -> :class:`Program`, spin its nodes, close it; return the exit code.

    ``args`` are the command-line arguments (``sys.argv`` when None), ROS arguments included.
    With ``usage`` and the node's ``parameters`` (``{name: Spec}``), ``-h``/``--help`` prints
    them and returns 0 without starting anything.
    """
    if usage is not None and asked_for_help(args):
        print_usage(usage, parameters or {})
        return 0
    import rclpy
    from rclpy.exceptions import ParameterException
    from rclpy.signals import SignalHandlerOptions

    def body(stop):
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
        program, interrupted, code = None, True, None
        try:
            program = start()
            executor = make_executor()
            for node in program.nodes:
                executor.add_node(node)
            stop.running()
            spin_until(executor, lambda: stop.requested or program.done())
            interrupted = stop.requested
        finally:
            stop.closing()
            teardown = program is None or program.teardown
            try:
                if program is not None:
                    code = program.close(interrupted)
                    for node in program.nodes if teardown else ():
                        node.destroy_node()
            finally:
                if teardown:
                    rclpy.try_shutdown()
        if code is not None:
            return code
        return interrupted_code if interrupted else 0

    return run_command(name, body, (ParameterException, *bad_input), interrupted_code)


def make_executor():
    """Return the executor that scales to hundreds of nodes in one process."""
    from rclpy.experimental import EventsExecutor
    return EventsExecutor()


def spin_until(executor, done, context=None):
    """Handle events until ``done()`` or the context shuts down."""
    import rclpy
    while rclpy.ok(context=context) and not done():
        try:
            executor.spin_once(timeout_sec=SPIN_PERIOD_S)
        except RuntimeError:
            # A context shut down mid-call surfaces as a pybind error.
            if rclpy.ok(context=context):
                raise
            return


def asked_for_help(args):
    """Whether ``-h`` or ``--help`` is among the arguments outside ``--ros-args``."""
    from rclpy.utilities import remove_ros_args
    argv = remove_ros_args(args=sys.argv if args is None else args)[1:]
    return bool({'-h', '--help'} & set(argv))


def print_usage(usage, specs):
    """Print the usage line and every parameter of ``specs`` (``--help``)."""
    from flectofold_ros.runtime.parameters import usage_lines
    print('\n'.join(usage_lines(usage, specs)))
