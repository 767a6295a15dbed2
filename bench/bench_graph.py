"""The graph at scale: panel processes' CPU, memory, rates, jitter, fan-out, start and stop.

Run with ``.venv/bin/python bench/bench_graph.py [--quick] [--counts 36,200,500,1000]
[--processes 1,2] [--json PATH]``. For each panel count N (a plane facade of a near-square
grid, generated from the demonstrator's YAML) and process count P, it starts P
``panel_group --group K/P`` processes in real time on a private ROS domain (localhost
discovery) and measures, in three phases:

* **rest**: no setpoint after the start (the panels hold closure 0);
* **moving**: a commander sends every panel a new setpoint, 0.2 / 0.8 alternately, every 4 s,
  all panels at once: in one ``/facade/setpoints`` message, as the coordinator does
  (``--setpoints facade``, the default), or with one rclpy publisher per
  ``/facade/<id>/setpoint`` (``--setpoints panel``);
* **observed** (not with ``--quick``; ``--no-observers`` leaves it out): still moving, with
  ``rerun_bridge`` (``viewer:=none``, to an ``.rrd``) and ``bag_recorder`` (its default
  topics) running; their exit summaries are kept.

How: CPU is utime+stime from ``/proc/<pid>/stat`` of every process of each panel process's
group over the window, as CPU seconds per wall second ("cores", so a busy machine changes the
figure less than wall time would); memory is the sum of ``VmRSS`` (``/proc/<pid>/status``),
the largest seen in the window. A probe (a child process, so its CPU is not counted with the
panels) subscribes to ``/facade/panel_states`` (one point per panel of a process; decoded with
:mod:`flectofold_ros.wire.panel_states`), ``/facade/joint_states``, ``/diagnostics`` and, for a
sample of up to 50 panels, ``/facade/<id>/{joint_states,pressure,closure}``: rates over the
window; jitter = p50/p99 of |arrival interval - nominal period| of ``panel_states`` per
publishing process, arrival as the probe's middleware stamped it (the message info; the JSON
also has the publisher's send times and the probe's callback times), or, where no process
publishes it, of the sample's per-panel ``closure`` (marked ``*``); the processes' own tick
statistics (``/diagnostics`` values
``tick_jitter_p50_s``, ``tick_jitter_p99_s``) where they report them. Start-up is from spawn
until every panel has been heard on ``panel_states`` (or, where it has no publisher, on its
own ``closure``). Fan-out is from the start of a commander burst to each panel's setpoint
callback: the panel processes run through a wrapper this script writes, which times every
callback of a ``/facade/<id>/setpoint`` subscription (today ``PanelNode._on_setpoint``) or,
for ``/facade/setpoints``, each panel's ``PanelProcess.offer`` (where it takes its entry), with
``time.monotonic_ns()`` (CLOCK_MONOTONIC is system-wide, so it compares with the commander's);
setpoints lost are those sent that no callback saw. Stop is from SIGINT to each process group
until the process has exited (SIGKILL after 10 s).

For the same N and P, a trivial rclpy peer runs the same phases: P processes of N/P nodes on
``EventsExecutor``, each node with one 10 Hz timer publishing a FluidPressure, a two-name
JointState and a Float64 and one setpoint subscription (for ``--setpoints facade`` one
``/facade/setpoints`` subscription per process instead; with the panel processes' Fast DDS
profile, ``flectofold_ros/fastdds_panel_process.xml``, where there is one, so that it starts
as they do); the table shows panels / peer.

Figures are printed as a table beside the issue's targets (benchmark figures, not assertions)
and written as JSON (``bench/results/graph.json``; ``--quick``: ``graph_quick.json``) with a
Markdown table next to it (same name, ``.md``).
"""

import argparse
from collections import deque
import ctypes
import json
import math
import os
from pathlib import Path
import platform
import queue
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

BENCH = Path(__file__).resolve().parent
ROOT = BENCH.parent
BIN = Path(sys.executable).parent
DEMONSTRATOR_YAML = ROOT / 'flectofold_model' / 'facade' / 'data' / 'demonstrator_6x6.yaml'
RESULTS = BENCH / 'results'
#: The panel processes' Fast DDS profile, when the code has one: the peer runs with it too.
PANEL_PROFILE = ROOT / 'flectofold_ros' / 'fastdds_panel_process.xml'

NOMINAL_HZ = 10.0  # the panel node's default publish_rate_hz
SAMPLE_SIZE = 50
BURST_PERIOD_S = 4.0
BURST_VALUES = (0.2, 0.8)
#: How the commander sends a burst (``--setpoints``).
SETPOINT_MODES = ('facade', 'panel')
STOP_KILL_S = 10.0
PHASES = ('rest', 'moving', 'observed')
TARGETS = {'rest_cores': 1.0, 'moving_cores': 1.5, 'rss_mib': 2048.0, 'rate_tolerance': 0.02,
           'jitter_p99_ms': 10.0, 'fanout_p99_ms': 50.0}
TARGETS_TEXT = ('1,000 panels in <= 2 processes: < 1.0 core at rest, < 1.5 cores all moving, '
                '< 2 GiB in all; publish rates within 2 % of the documented 10 Hz; jitter p99 '
                '< 10 ms; fan-out p99 < 50 ms')
SETPOINT_TOPIC = re.compile(r'/facade/(r\d{2}c\d{2})/setpoint$')
CLK_TCK = os.sysconf('SC_CLK_TCK')


# == child roles ================================================================================
# The probe, the commander and the peer run as children of this script
# (``python bench_graph.py _probe ...``), each with its own rclpy context.

def _rclpy_init():
    import rclpy
    from rclpy.signals import SignalHandlerOptions
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    return rclpy


def _stop_flag():
    """SIGINT / SIGTERM set the returned list (no KeyboardInterrupt in a callback)."""
    stop = []
    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, lambda *_: stop.append(1))
    return stop


def _emit(**event):
    sys.stdout.write(json.dumps(event) + '\n')
    sys.stdout.flush()


def _percentiles_ms(values_s):
    import numpy as np
    if len(values_s) == 0:
        return None, None
    values = np.asarray(values_s) * 1e3
    return float(np.percentile(values, 50)), float(np.percentile(values, 99))


def _jitter(arrivals_ns, period_s):
    """|arrival interval - period| [s] of one stream's arrival times."""
    import numpy as np
    if len(arrivals_ns) < 2:
        return np.zeros(0)
    return np.abs(np.diff(np.asarray(arrivals_ns, dtype=np.int64)) * 1e-9 - period_s)


def probe_main(argv):
    """Subscribe, report start-up, then count and time arrivals between window commands."""
    parser = argparse.ArgumentParser(prog='bench_graph _probe')
    parser.add_argument('--ids-file', required=True, help='lines "<panel id> <process index>"')
    parser.add_argument('--sample', required=True)
    parser.add_argument('--startup', choices=('panel_states', 'closure'),
                        default='panel_states', help='where start-up is heard first')
    options = parser.parse_args(argv)
    stop = _stop_flag()
    process_of = {}
    for line in Path(options.ids_file).read_text().split('\n'):
        if line.strip():
            panel_id, index = line.split()
            process_of[panel_id] = int(index)
    all_ids = list(process_of)
    sample = [panel_id for panel_id in options.sample.split(',') if panel_id]

    rclpy = _rclpy_init()
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.experimental import EventsExecutor
    from rclpy.node import Node
    from rclpy.signals import SignalHandlerOptions

    from flectofold_ros.wire import contract, panel_states
    from flectofold_ros.runtime.interfaces import subscription

    observer = contract.OBSERVER
    node = Node('bench_probe')
    executor = EventsExecutor()
    executor.add_node(node)
    # The facade-level topics on a context of their own, spun by a thread with the
    # message info (the middleware's reception time and the publisher's send time and
    # sequence number), which the events executor of these wheels cannot hand over.
    timing_context = Context()
    rclpy.init(context=timing_context, signal_handler_options=SignalHandlerOptions.NO)
    timing = Node('bench_probe_timing', context=timing_context)
    timing_executor = SingleThreadedExecutor(context=timing_context)
    timing_executor.add_node(timing)
    lock = threading.Lock()
    arrivals = {}  # key -> callback times [ns, monotonic] in the window
    stamps = {}  # key -> (received [ns], sent [ns], sequence) in the window (facade topics)
    state = {'window': False, 'heard_states': set(), 'heard_closure': set(), 'startup': None,
             'mode': None, 'points': {}, 'states_bad': 0, 'tick': {}, 'diag_messages': 0,
             'behind_max_s': 0.0, 'flaps': {}, 'drop_fallback': False, 'bridge': []}
    fallback = []

    def arrived(key, info=None, now=None):
        if state['window']:
            arrivals.setdefault(key, []).append(now or time.monotonic_ns())
            if info is not None:
                stamps.setdefault(key, []).append((info['received_timestamp'],
                                                   info['source_timestamp'],
                                                   info['publication_sequence_number']))

    def check_started(now):
        # with the lock held
        for via, heard in (('panel_states', state['heard_states']),
                           ('closure', state['heard_closure'] if fallback else ())):
            if len(heard) >= len(all_ids) and heard.issuperset(all_ids):
                break
        else:
            return
        state['startup'] = now
        state['drop_fallback'] = True
        _emit(event='startup', t_ns=now, via=via)

    def on_panel_states(message, info):
        now = time.monotonic_ns()
        try:
            table = panel_states.unpack(message)
        except ValueError:
            state['states_bad'] += 1
            return
        if not len(table):
            return
        process = process_of.get(f'r{int(table["row"][0]):02d}c{int(table["column"][0]):02d}',
                                 -1)
        with lock:
            state['points'][process] = len(table)
            arrived(('panel_states', process), info, now)
            if state['startup'] is None:
                state['heard_states'].update(panel_states.panel_ids(table))
                check_started(now)

    def on_flaps(message, info):
        now = time.monotonic_ns()
        if not message.name:
            return
        process = process_of.get(message.name[0].rsplit('_flap', 1)[0], -1)
        with lock:
            state['flaps'][process] = len(message.name)
            arrived(('joint_states', process), info, now)

    def on_diagnostics(message):
        now = time.monotonic_ns()
        state['diag_messages'] += state['window']
        for status in message.status:
            if status.hardware_id == contract.RERUN_BRIDGE_NODE and state['window']:
                counts = {v.key: v.value for v in status.values}
                state['bridge'].append((now, int(counts['meshes_logged']),
                                        int(counts['panels_remeshed'])))
                continue
            found = {}
            for value in status.values:
                if value.key in ('tick_jitter_p50_s', 'tick_jitter_p99_s', 'behind_by_s'):
                    try:
                        found[value.key] = float(value.value)
                    except ValueError:
                        pass
            if 'behind_by_s' in found and state['window']:
                state['behind_max_s'] = max(state['behind_max_s'], found['behind_by_s'])
            if 'tick_jitter_p99_s' in found and state['window']:
                state['tick'][status.name] = (found.get('tick_jitter_p50_s'),
                                              found['tick_jitter_p99_s'])

    def on_closure(panel_id):
        def callback(message):
            if state['startup'] is None:
                with lock:
                    state['heard_closure'].add(panel_id)
                    check_started(time.monotonic_ns())
            arrived(('closure', panel_id))
        return callback

    subscription(timing, contract.PANEL_STATES, on_panel_states, observer)
    subscription(timing, contract.FACADE_JOINT_STATES, on_flaps, observer)
    subscription(node, contract.DIAGNOSTICS, on_diagnostics, observer)
    for panel_id in sample:
        subscription(node, contract.JOINT_STATES.of(panel_id),
                     lambda m, p=panel_id: arrived(('joint_states', p)))
        subscription(node, contract.PRESSURE.of(panel_id),
                     lambda m, p=panel_id: arrived(('pressure', p)))
        subscription(node, contract.CLOSURE.of(panel_id), on_closure(panel_id))

    def use_closures():
        state['mode'] = 'closure'
        fallback.extend(subscription(node, contract.CLOSURE.of(panel_id), on_closure(panel_id))
                        for panel_id in all_ids if panel_id not in sample)
        fallback.append(None)  # (also when every panel is in the sample)

    if options.startup == 'closure':
        use_closures()

    def spin_timing():
        while not stop:
            try:
                timing_executor.spin_once(timeout_sec=0.1)
            except Exception:  # a context shut down under it
                if not stop:
                    raise

    threading.Thread(target=spin_timing, daemon=True).start()
    commands = deque()

    def read_commands():
        for line in sys.stdin:
            commands.append(line.strip())
        commands.append('quit')

    threading.Thread(target=read_commands, daemon=True).start()
    _emit(event='ready', t_ns=time.monotonic_ns())
    per_panel_seen_ns = None
    window_start = None
    last_look = 0.0
    while not stop:
        executor.spin_once(timeout_sec=0.05)
        if state['drop_fallback']:
            state['drop_fallback'] = False
            for extra in fallback:  # 10 messages/s each: not kept past the start
                if extra is not None:
                    node.destroy_subscription(extra)
        if state['startup'] is None and state['mode'] is None \
                and time.monotonic() - last_look > 0.5:
            # Fall back to the panels' own closure when their processes publish per-panel
            # topics but, 3 s on, still no panel_states.
            last_look = time.monotonic()
            if timing.count_publishers(contract.PANEL_STATES.name) == 0 and sample \
                    and node.count_publishers(contract.CLOSURE.of(sample[0]).name) > 0:
                per_panel_seen_ns = per_panel_seen_ns or time.monotonic_ns()
                if time.monotonic_ns() - per_panel_seen_ns > 3e9:
                    with lock:
                        use_closures()
                    _emit(event='fallback', reason='no /facade/panel_states publisher')
        while commands:
            command = commands.popleft()
            if command == 'window':
                with lock:
                    arrivals.clear()
                    stamps.clear()
                    state.update(window=True, tick={}, diag_messages=0, behind_max_s=0.0,
                                 bridge=[])
                    window_start = time.monotonic_ns()
                _emit(event='window', t_ns=window_start)
            elif command == 'report':
                with lock:
                    end = time.monotonic_ns()
                    state['window'] = False
                _emit(event='report', **probe_report(arrivals, stamps, state, sample,
                                                     window_start, end))
            elif command == 'heard':
                _emit(event='heard', states=len(state['heard_states']),
                      closure=len(state['heard_closure']), mode=state['mode'])
            elif command == 'quit':
                stop.append(1)
    os._exit(0)  # nothing to keep: leave without tearing the two contexts down


def probe_report(arrivals, stamps, state, sample, start_ns, end_ns):
    """Return the probe's figures of one window, JSON-ready.

    Facade-level topics, per publishing process: rate and jitter from the middleware's
    reception times (the table's), from the publisher's send times and from the callback
    times; messages missing from the publisher's sequence numbers.
    """
    import numpy as np
    period_s = 1.0 / NOMINAL_HZ
    window_s = (end_ns - start_ns) * 1e-9
    processes = {}
    for (kind, key), times in arrivals.items():
        if kind not in ('panel_states', 'joint_states') or not isinstance(key, int):
            continue
        rows = stamps.get((kind, key)) or [(0, 0, 0)][:0]
        received, sent, sequence = (np.array([row[i] for row in rows], dtype=np.int64)
                                    for i in range(3))
        p50, p99 = _percentiles_ms(_jitter(received, period_s))
        s50, s99 = _percentiles_ms(_jitter(sent, period_s))
        c50, c99 = _percentiles_ms(_jitter(times, period_s))
        gaps = np.diff(sequence) if len(sequence) > 1 else np.zeros(0)
        processes.setdefault(str(key), {})[kind] = {
            'hz': _rate(received if len(received) else times, window_s), 'count': len(times),
            'jitter_p50_ms': p50, 'jitter_p99_ms': p99,
            'send_jitter_p50_ms': s50, 'send_jitter_p99_ms': s99,
            'callback_jitter_p50_ms': c50, 'callback_jitter_p99_ms': c99,
            'missing': int(np.sum(gaps[gaps > 1] - 1))}
    for key, count in state['points'].items():
        processes.setdefault(str(key), {}).setdefault('panel_states', {})['points'] = count
    for key, count in state['flaps'].items():
        processes.setdefault(str(key), {}).setdefault('joint_states', {})['names'] = count
    per_panel = {}
    for suffix in ('joint_states', 'pressure', 'closure'):
        rates = [_rate(arrivals.get((suffix, panel_id), ()), window_s) for panel_id in sample]
        jitter = np.concatenate([_jitter(arrivals.get((suffix, panel_id), ()), period_s)
                                 for panel_id in sample] or [np.zeros(0)])
        p50, p99 = _percentiles_ms(jitter)
        per_panel[suffix] = {'hz_mean': float(np.mean(rates)) if rates else None,
                             'hz_min': float(np.min(rates)) if rates else None,
                             'jitter_p50_ms': p50, 'jitter_p99_ms': p99}
    return {'window_s': window_s, 'processes': processes, 'per_panel': per_panel,
            'sample': len(sample), 'tick_jitter': state['tick'],
            'diagnostics_hz': state['diag_messages'] / window_s,
            'behind_max_s': state['behind_max_s'], 'panel_states_bad': state['states_bad'],
            'bridge': _bridge_rates(state['bridge'])}


def _bridge_rates(reports):
    """Return the Rerun bridge's facade meshes and panel re-meshes per second in the window.

    Between its first and last ``/diagnostics`` report there (``(t_ns, meshes, panels)``,
    1 Hz); None with fewer than two.
    """
    if len(reports) < 2:
        return None
    (t0, meshes0, panels0), (t1, meshes1, panels1) = reports[0], reports[-1]
    span_s = (t1 - t0) * 1e-9
    return {'span_s': span_s, 'facade_meshes_per_s': (meshes1 - meshes0) / span_s,
            'panels_remeshed_per_s': (panels1 - panels0) / span_s}


def _rate(arrivals_ns, window_s):
    """Return messages per second over the span of the arrivals.

    A count over the window is off by up to one message either way: 2 % of 5 s at 10 Hz.
    """
    if len(arrivals_ns) < 3:
        return len(arrivals_ns) / window_s
    return (len(arrivals_ns) - 1) / ((arrivals_ns[-1] - arrivals_ns[0]) * 1e-9)


def commander_main(argv):
    """Send every panel a burst of setpoints every period: one facade message, or one each."""
    parser = argparse.ArgumentParser(prog='bench_graph _commander')
    parser.add_argument('--ids-file', required=True)
    parser.add_argument('--log', required=True)
    parser.add_argument('--period', type=float, default=BURST_PERIOD_S)
    parser.add_argument('--match-timeout', type=float, default=120.0)
    parser.add_argument('--setpoints', choices=SETPOINT_MODES, default='facade')
    options = parser.parse_args(argv)
    stop = _stop_flag()
    lines = [line.split() for line in Path(options.ids_file).read_text().split('\n')
             if line.strip()]
    ids = [words[0] for words in lines]
    processes = len({words[1] for words in lines})
    import rclpy.node
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64

    from flectofold_ros.wire import contract
    from flectofold_ros.runtime.interfaces import publisher
    # Loaded ahead; joins the graph on "go" (so the rest phase has no commander in it).
    go = threading.Event()
    threading.Thread(target=lambda: (sys.stdin.readline(), go.set()), daemon=True).start()
    _emit(event='loaded')
    while not stop and not go.wait(0.1):
        pass
    if stop:
        os._exit(0)
    _rclpy_init()
    node = rclpy.node.Node('bench_commander')
    facade = options.setpoints == 'facade'
    if facade:  # one message per burst; matched once every process subscribes
        facade_publisher = publisher(node, contract.FACADE_SETPOINTS)
        publishers = []
    else:
        publishers = [(panel_id, publisher(node, contract.SETPOINT.of(panel_id)))
                      for panel_id in ids]

    def unmatched_count():
        if facade:
            return max(0, processes - facade_publisher.get_subscription_count())
        return sum(publisher.get_subscription_count() == 0 for _, publisher in publishers)

    deadline = time.monotonic() + options.match_timeout
    unmatched = unmatched_count()
    while not stop and time.monotonic() < deadline:
        unmatched = unmatched_count()
        if not unmatched:
            break
        time.sleep(0.2)
    # The subscriber's side of the match may lag the publisher's: a moment for it.
    time.sleep(0.5)
    _emit(event='matched', unmatched=unmatched, t_ns=time.monotonic_ns())
    records, burst = [], 0
    next_burst = time.monotonic()
    with open(options.log, 'w') as log:
        while not stop:
            if time.monotonic() >= next_burst:
                value = BURST_VALUES[burst % 2]
                message = Float64(data=value)
                start = time.monotonic_ns()
                if facade:
                    records.extend(f'{burst} {start} {panel_id} {value!r}\n' for panel_id in ids)
                    facade_publisher.publish(JointState(name=ids, position=[value] * len(ids)))
                for panel_id, setpoint in publishers:
                    records.append(f'{burst} {time.monotonic_ns()} {panel_id} {value!r}\n')
                    setpoint.publish(message)
                end = time.monotonic_ns()
                log.write(f'# burst {burst} {start} {end}\n')
                log.writelines(records)
                log.flush()
                records.clear()
                _emit(event='burst', burst=burst, t0_ns=start, t1_ns=end)
                burst += 1
                next_burst += options.period
            time.sleep(min(0.05, max(0.0, next_burst - time.monotonic())))
    node.destroy_node()
    rclpy.try_shutdown()
    os._exit(0)


def peer_main(argv):
    """Run the trivial peer: N nodes, three 10 Hz topics each, setpoints as the panels have."""
    parser = argparse.ArgumentParser(prog='bench_graph _peer')
    parser.add_argument('--ids', required=True)
    parser.add_argument('--setpoints', choices=SETPOINT_MODES, default='facade')
    options = parser.parse_args(argv)
    stop = _stop_flag()
    rclpy = _rclpy_init()
    from rclpy.experimental import EventsExecutor
    from rclpy.node import Node
    from sensor_msgs.msg import FluidPressure, JointState
    from std_msgs.msg import Float64

    from flectofold_ros.wire import contract
    from flectofold_ros.runtime.interfaces import publisher, subscription

    class Peer(Node):
        def __init__(self, panel_id):
            super().__init__('peer', namespace=contract.panel_namespace(panel_id))
            self.panel_id = panel_id
            self.names = contract.flap_joint_names(panel_id)
            self.setpoint = 0.0
            self.pressure = publisher(self, contract.PRESSURE.of(panel_id))
            self.joints = publisher(self, contract.JOINT_STATES.of(panel_id))
            self.closure = publisher(self, contract.CLOSURE.of(panel_id))
            if options.setpoints == 'panel':
                subscription(self, contract.SETPOINT.of(panel_id), self.on_setpoint)
            self.create_timer(1.0 / NOMINAL_HZ, self.tick)

        def on_setpoint(self, message):
            self.setpoint = message.data

        def tick(self):
            stamp = self.get_clock().now().to_msg()
            pressure = FluidPressure(fluid_pressure=101325.0 + 1e4 * self.setpoint,
                                     variance=400.0)
            pressure.header.stamp, pressure.header.frame_id = stamp, self.panel_id
            self.pressure.publish(pressure)
            joints = JointState(name=self.names, position=[self.setpoint, self.setpoint])
            joints.header.stamp = stamp
            self.joints.publish(joints)
            self.closure.publish(Float64(data=self.setpoint))

    executor = EventsExecutor()
    nodes = []
    for panel_id in options.ids.split(','):
        if stop:
            os._exit(0)
        nodes.append(Peer(panel_id))
        executor.add_node(nodes[-1])
    if options.setpoints == 'facade':  # one subscription per process, as the panels have
        by_id = {peer.panel_id: peer for peer in nodes}

        def on_setpoints(message):
            for name, closure in zip(message.name, message.position):
                if name in by_id:
                    by_id[name].setpoint = closure

        subscription(nodes[0], contract.FACADE_SETPOINTS, on_setpoints)
    print(f'peer: {len(nodes)} nodes ready', flush=True)
    while not stop:
        executor.spin_once(timeout_sec=0.1)  # EventsExecutor.spin() never returns here
    for peer in nodes:
        peer.destroy_node()
    rclpy.try_shutdown()
    sys.stdout.flush()
    os._exit(0)


# == the wrapper the panel processes run through ================================================

WRAPPER = r'''"""Written by bench/bench_graph.py: panel_group with its setpoints timed.

$BENCH_SETPOINTS "panel": every callback of a /facade/<id>/setpoint subscription
(PanelNode._on_setpoint today, whatever the node calls it) is wrapped to note
(time.monotonic_ns(), panel id, value). "facade": PanelProcess.offer, where each panel of the
process takes its entry of a /facade/setpoints message, is wrapped to note the same. A thread
writes the notes to $BENCH_SETPOINT_LOG every 0.5 s, and os._exit (the panel processes' fast
exit) and atexit write the rest first. "# wrapped" lines name what was wrapped.
"""
import atexit
from collections import deque
import inspect
import os
import re
import sys
import threading
import time

_TOPIC = re.compile(r'/facade/(r\d{2}c\d{2})/setpoint$')
_notes = deque()
_lock = threading.Lock()
_out = open(os.environ['BENCH_SETPOINT_LOG'], 'w', buffering=1 << 16)


def _write():
    with _lock:
        lines = []
        while _notes:
            lines.append('%d %s %r\n' % _notes.popleft())
        if not _out.closed:
            _out.write(''.join(lines))
            _out.flush()


def _writer():
    while True:
        time.sleep(0.5)
        _write()


threading.Thread(target=_writer, daemon=True).start()
atexit.register(_write)
_real_exit = os._exit


def _exit(code):
    _write()
    _real_exit(code)


os._exit = _exit


def _timed(callback, panel_id):
    def note(message):
        now = time.monotonic_ns()
        try:
            value = float(message.data)
        except Exception:  # a raw subscription, another type: matched by panel and time
            value = float('nan')
        _notes.append((now, panel_id, value))
    try:
        inspect.signature(callback).bind(object())
    except TypeError:
        def timed(message, info):
            note(message)
            return callback(message, info)
    else:
        def timed(message):
            note(message)
            return callback(message)
    with _lock:
        _out.write('# wrapped %s %s\n' % (panel_id, getattr(callback, '__qualname__',
                                                            repr(callback))))
    return timed


# The package subscribes only through flectofold_ros.runtime.interfaces.subscription (its contract
# test checks that); the panel module's name for it is the one to wrap.
import flectofold_ros.nodes.panel as _panel  # noqa: E402  (fails loudly if the node is gone)

_subscription = _panel.subscription


def _timed_subscription(node, topic, callback, *args, **kwargs):
    match = _TOPIC.search(topic.name)
    if match:
        callback = _timed(callback, match.group(1))
    return _subscription(node, topic, callback, *args, **kwargs)


def _timed_offer(offer):
    def timed(self, index, value, logger):
        _notes.append((time.monotonic_ns(), self.panels[index].panel_id, float(value)))
        return offer(self, index, value, logger)
    return timed


if os.environ.get('BENCH_SETPOINTS') == 'facade':
    _panel.PanelProcess.offer = _timed_offer(_panel.PanelProcess.offer)
    with _lock:
        _out.write('# wrapped facade PanelProcess.offer\n')
else:
    _panel.subscription = _timed_subscription
from flectofold_ros.runtime.executables import panel_group  # noqa: E402

sys.argv = ['panel_group', *sys.argv[1:]]
panel_group()
'''


# == processes, /proc ===========================================================================

def _die_with_parent():
    """In the child: SIGKILL when this script dies, so a killed run leaves nothing behind.

    And SIGINT, SIGTERM back to their defaults: started as a background job, this script
    ignores SIGINT, and an ignored signal stays ignored across exec (the panel processes
    keep it so, as a shell's background job should), so no SIGINT would stop them.
    """
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        ctypes.CDLL('libc.so.6', use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except OSError:
        pass


class Child:
    """A child process leading its own process group; output to a file or a JSON-line pipe."""

    def __init__(self, name, command, env, log_path, events=False):
        self.name = name
        self.log_path = Path(log_path)
        self.events = queue.Queue()
        self.stop_s = None
        self._log = open(self.log_path, 'w')
        self.process = subprocess.Popen(
            command, env=env, stdin=subprocess.PIPE if events else subprocess.DEVNULL,
            stdout=subprocess.PIPE if events else self._log, stderr=self._log, text=True,
            start_new_session=True, preexec_fn=_die_with_parent)
        self.pid = self.process.pid
        self.spawned_ns = time.monotonic_ns()
        if events:
            threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.process.stdout:
            try:
                self.events.put(json.loads(line))
            except ValueError:
                self._log.write(line)
        self.events.put(None)

    def expect(self, event, timeout_s):
        """Return the next event named ``event`` (others are dropped), None on timeout/exit."""
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            try:
                item = self.events.get(timeout=min(left, 1.0))
            except queue.Empty:
                continue
            if item is None:
                return None
            if item.get('event') == event:
                return item
        return None

    def send(self, command):
        try:
            self.process.stdin.write(command + '\n')
            self.process.stdin.flush()
        except (BrokenPipeError, ValueError, OSError):
            pass

    def alive(self):
        return self.process.poll() is None

    def log_tail(self, lines=6):
        self._log.flush()
        try:
            text = self.log_path.read_text(errors='replace').strip().split('\n')
        except OSError:
            return ''
        return ' | '.join(line.strip() for line in text[-lines:])

    def interrupt(self):
        try:
            os.killpg(self.pid, signal.SIGINT)
        except ProcessLookupError:
            pass
        self._interrupted = time.monotonic()

    def wait_stopped(self, timeout_s=STOP_KILL_S):
        """After :meth:`interrupt`: wait for the exit, SIGKILL the group after ``timeout_s``."""
        start = getattr(self, '_interrupted', time.monotonic())
        try:
            self.process.wait(timeout=max(0.0, start + timeout_s - time.monotonic()))
            self.stop_s = time.monotonic() - start
        except subprocess.TimeoutExpired:
            self.kill()
            self.stop_s = None
        return self.stop_s

    def kill(self):
        try:
            os.killpg(self.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            pass
        self._log.flush()


class Children:
    """Every child of a measurement; :meth:`close` kills whatever still runs."""

    def __init__(self):
        self.children = []

    def start(self, *args, **kwargs):
        child = Child(*args, **kwargs)
        self.children.append(child)
        return child

    def close(self):
        for child in self.children:
            if child.alive():
                child.kill()
            child._log.close()


def _group_members(pgid):
    members = []
    for entry in os.scandir('/proc'):
        if not entry.name.isdigit():
            continue
        try:
            with open(f'/proc/{entry.name}/stat') as stat:
                text = stat.read()
        except OSError:
            continue
        fields = text[text.rindex(')') + 2:].split()
        if int(fields[2]) == pgid:
            members.append((int(entry.name), fields))
    return members


def cpu_seconds(pgid):
    """Return utime + stime [s] of every process in group ``pgid`` (``/proc/<pid>/stat``)."""
    return sum(int(fields[11]) + int(fields[12]) for _, fields in _group_members(pgid)) / CLK_TCK


def rss_mib(pgid):
    """Sum of ``VmRSS`` [MiB] of group ``pgid``'s processes."""
    total = 0
    for pid, _ in _group_members(pgid):
        try:
            with open(f'/proc/{pid}/status') as status:
                for line in status:
                    if line.startswith('VmRSS:'):
                        total += int(line.split()[1])
        except OSError:
            pass
    return total / 1024.0


# == one measurement ============================================================================

def grid_for(count):
    """Rows x columns of a near-square grid of ``count`` panels (rows <= columns)."""
    rows = max(r for r in range(1, math.isqrt(count) + 1) if count % r == 0)
    return rows, count // rows


def write_facade(count, directory):
    """Write a plane facade of ``count`` panels from the demonstrator's YAML; return its path."""
    import yaml
    rows, columns = grid_for(count)
    if rows > 99 or columns > 99:
        raise SystemExit(f'{count} panels: a {rows} x {columns} grid has no rNNcNN ids')
    description = yaml.safe_load(DEMONSTRATOR_YAML.read_text())
    description['name'] = f'bench-plane-{rows}x{columns}'
    description['surface'] = {'type': 'plane', 'width_m': round(columns * 1.1, 6),
                              'height_m': round(rows * 1.1, 6)}
    description['grid'].update(rows=rows, columns=columns)
    path = Path(directory) / f'facade_{count}.yaml'
    path.write_text(yaml.safe_dump(description, sort_keys=False))
    return path


def group_slice(ids, group, groups):
    """Return the ``panel_group --group K/N`` slice (flectofold_ros.nodes.panel_group's rule)."""
    return ids[group * len(ids) // groups:(group + 1) * len(ids) // groups]


def sample_of(ids):
    step = max(1, len(ids) / SAMPLE_SIZE)
    return [ids[int(i * step)] for i in range(min(SAMPLE_SIZE, len(ids)))]


class Setup:
    """Paths, environment and options shared by one configuration's measurements."""

    def __init__(self, options, count, processes, domain, directory):
        self.options, self.count, self.processes = options, count, processes
        self.directory = Path(directory)
        self.facade = write_facade(count, directory)
        from flectofold_model.facade import load_facade
        self.ids = list(load_facade(self.facade).panel_ids)
        self.slices = [group_slice(self.ids, k, processes) for k in range(processes)]
        self.ids_file = self.directory / 'ids.txt'
        self.ids_file.write_text(''.join(f'{panel_id} {k}\n' for k, part in
                                         enumerate(self.slices) for panel_id in part))
        self.sample = sample_of(self.ids)
        self.wrapper = self.directory / 'panel_wrapper.py'
        self.wrapper.write_text(WRAPPER)
        self.env = dict(os.environ, ROS_DOMAIN_ID=str(domain),
                        ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', PYTHONUNBUFFERED='1',
                        RCUTILS_COLORIZED_OUTPUT='0', AMENT_PREFIX_PATH=str(BIN.parent))
        self.env.pop('ROS_STATIC_PEERS', None)


class _Kernels:
    """The simulation's kernels compiled (or their cache checked) once, before any panel starts.

    In a child process while the first probe starts; :meth:`wait` before spawning panels, so
    that no start-up measured includes a compile.
    """

    process = None

    def start(self):
        self.process = subprocess.Popen(
            [sys.executable, '-c', 'from flectofold_model.control import compile_kernels; '
             'compile_kernels()'], start_new_session=True, preexec_fn=_die_with_parent)

    def wait(self):
        if self.process is not None:
            try:
                code = self.process.wait(timeout=600)
            except subprocess.TimeoutExpired:
                self.process.kill()
                code = 'timeout'
            self.process = None
            if code != 0:
                raise SystemExit(f'compiling the kernels failed ({code})')


KERNELS = _Kernels()


_T0 = time.monotonic()


def log(text):
    print(f'[{time.monotonic() - _T0:5.0f} s] {text}' if text else '', flush=True)


def measure(setup, kind, children):
    """Start ``kind`` ('panels' or 'peer'), run the phases, stop it; return its figures."""
    options, directory = setup.options, setup.directory / kind
    directory.mkdir()
    env = setup.env
    result = {'kind': kind, 'phases': {}, 'error': None}
    me = [sys.executable, str(Path(__file__).resolve())]
    probe = children.start('probe', [*me, '_probe', '--ids-file', str(setup.ids_file),
                                     '--sample', ','.join(setup.sample),
                                     '--startup', startup_topic(kind)],
                           env, directory / 'probe.log', events=True)
    commander = children.start('commander', [*me, '_commander', '--ids-file',
                                             str(setup.ids_file), '--log',
                                             str(directory / 'commander.log'),
                                             '--setpoints', options.setpoints],
                               env, directory / 'commander_err.log', events=True)
    if probe.expect('ready', 60.0) is None:
        result['error'] = f'probe did not start: {probe.log_tail()}'
        return result
    KERNELS.wait()
    systems = []
    for k, part in enumerate(setup.slices):
        if kind == 'panels':
            command = [sys.executable, str(setup.wrapper), '--group', f'{k}/{setup.processes}',
                       '--facade', str(setup.facade), '--ros-args',
                       '-p', 'setpoint_timeout_s:=600.0']
            child_env = dict(env, BENCH_SETPOINT_LOG=str(directory / f'setpoints_{k}.log'),
                             BENCH_SETPOINTS=options.setpoints)
        else:
            command = [*me, '_peer', '--ids', ','.join(part), '--setpoints', options.setpoints]
            child_env = dict(env)
            if PANEL_PROFILE.exists() and not any(
                    env.get(name) for name in ('FASTRTPS_DEFAULT_PROFILES_FILE',
                                               'FASTDDS_DEFAULT_PROFILES_FILE')):
                # the panel processes' Fast DDS profile (no pairing of a process's own
                # endpoints), so that the peer starts as fast as they can
                child_env['FASTRTPS_DEFAULT_PROFILES_FILE'] = str(PANEL_PROFILE)
                result['fastdds_profile'] = str(PANEL_PROFILE)
        systems.append(children.start(f'{kind}{k}', command, child_env,
                                      directory / f'{kind}_{k}.log'))
    spawned = systems[0].spawned_ns
    deadline = time.monotonic() + options.startup_timeout
    started = None
    while time.monotonic() < deadline:
        started = probe.expect('startup', 1.0)
        if started is not None:
            break
        dead = [child for child in systems if not child.alive()]
        if dead:
            result['error'] = (f'{dead[0].name} exited with code {dead[0].process.returncode} '
                               f'while starting: {dead[0].log_tail()}')
            break
    if started is None:
        if result['error'] is None:
            probe.send('heard')
            heard = probe.expect('heard', 5.0) or {}
            result['error'] = (f'did not start within {options.startup_timeout:g} s (heard '
                               f'{max(heard.get("states", 0), heard.get("closure", 0))} of '
                               f'{len(setup.ids)} panels)')
        for child in systems:
            child.interrupt()
        for child in systems:
            child.wait_stopped()
        return result
    result['startup_s'] = (started['t_ns'] - spawned) * 1e-9
    result['startup_via'] = started['via']
    log(f'  {kind}: started in {result["startup_s"]:.1f} s (heard on {started["via"]})')

    observers = []
    try:
        time.sleep(options.settle)
        result['phases']['rest'] = window(probe, systems, options.window)
        log(f'  {kind}: rest {result["phases"]["rest"]["cores"]:.2f} cores; commander joins')
        commander.send('go')
        matched = commander.expect('matched', 150.0)
        if matched is None:
            raise RuntimeError(f'the commander did not match: {commander.log_tail()}')
        result['commander_unmatched'] = matched['unmatched']
        time.sleep(1.0 if options.quick else BURST_PERIOD_S)  # a burst: every panel moving
        result['phases']['moving'] = window(probe, systems, options.window)
        log(f'  {kind}: moving {result["phases"]["moving"]["cores"]:.2f} cores')
        if kind == 'panels' and options.observers:
            observers = start_observers(setup, children, directory)
            up = wait_observers(observers, 180.0)
            if up is not True:
                result['observer_error'] = up
            else:
                time.sleep(options.settle)
                result['phases']['observed'] = window(probe, systems, options.window,
                                                      observers)
            result['observers'] = stop_observers(observers)
        commander.interrupt()
        commander.wait_stopped()
        if kind == 'panels':  # the last bursts' callbacks, however late they come
            drain([directory / f'setpoints_{k}.log' for k in range(setup.processes)],
                  quiet_s=1.0 if options.quick else 2.0, bound_s=20.0)
        else:
            time.sleep(1.0)
    except RuntimeError as error:
        result['error'] = str(error)
    finally:
        for child in [*observers, commander]:
            if child.alive():
                child.kill()
        for child in systems:
            child.interrupt()
        result['stop_s'] = [child.wait_stopped() for child in systems]
        log(f'  {kind}: stopped ({", ".join(_fmt(s, ".2f", "killed") for s in result["stop_s"])}'
            f' s)')
        probe.send('quit')
        probe.wait_stopped(5.0)
    result['exit_codes'] = [child.process.returncode for child in systems]
    if kind == 'panels':  # the wrapper's notes of what it wrapped, complete once stopped
        result['setpoint_callbacks_wrapped'] = [
            _count_wrapped(directory / f'setpoints_{k}.log') for k in range(setup.processes)]
    if 'moving' in result['phases']:
        callbacks_logs = ([directory / f'setpoints_{k}.log' for k in range(setup.processes)]
                          if kind == 'panels' else [])
        fanout(result, directory / 'commander.log', callbacks_logs, len(setup.ids))
    return result


def panels_publish_states():
    """Whether the panel nodes' source publishes ``/facade/panel_states`` (the rewrite)."""
    nodes = ROOT / 'flectofold_ros' / 'nodes'
    return any('PANEL_STATES' in (nodes / name).read_text()
               for name in ('panel.py', 'panel_group.py') if (nodes / name).exists())


def startup_topic(kind):
    """Where the probe hears a start first: panel_states, or each panel's closure.

    With ``panel_states`` the probe still falls back to the closures when, 3 s after the
    first panel's closure has a publisher, ``panel_states`` has none.
    """
    return 'panel_states' if kind == 'panels' and panels_publish_states() else 'closure'


def drain(logs, quiet_s, bound_s):
    """Wait until the callback logs have not grown for ``quiet_s`` (at most ``bound_s``)."""
    def size():
        return sum(path.stat().st_size for path in logs if path.exists())
    deadline, last, since = time.monotonic() + bound_s, -1, time.monotonic()
    while time.monotonic() < deadline:
        now = size()
        if now != last:
            last, since = now, time.monotonic()
        elif time.monotonic() - since >= quiet_s:
            return
        time.sleep(0.25)


def _count_wrapped(path):
    try:
        return sum(line.startswith('# wrapped') for line in open(path))
    except OSError:
        return 0


def window(probe, systems, window_s, observers=()):
    """Measure CPU, RSS and the probe's figures over ``window_s``; return them."""
    probe.send('window')
    if probe.expect('window', 10.0) is None:
        raise RuntimeError('the probe did not answer')
    groups = [child.pid for child in systems]
    extra = [child.pid for child in observers]
    cpu0 = {pid: cpu_seconds(pid) for pid in groups + extra + [probe.pid]}
    start = time.monotonic()
    rss_max = dict.fromkeys(groups + extra, 0.0)
    while (left := start + window_s - time.monotonic()) > 0:
        for pid in rss_max:
            rss_max[pid] = max(rss_max[pid], rss_mib(pid))
        dead = [child for child in systems if not child.alive()]
        if dead:
            raise RuntimeError(f'{dead[0].name} exited with code '
                               f'{dead[0].process.returncode}: {dead[0].log_tail()}')
        time.sleep(min(1.0, left))
    wall = time.monotonic() - start
    cpu = {pid: (cpu_seconds(pid) - cpu0[pid]) / wall for pid in cpu0}
    probe.send('report')
    report = probe.expect('report', 20.0)
    if report is None:
        raise RuntimeError('the probe sent no report')
    report.pop('event')
    figures = {'window_s': wall,
               'cores': sum(cpu[pid] for pid in groups),
               'cores_per_process': [cpu[pid] for pid in groups],
               'rss_mib': sum(rss_max[pid] for pid in groups),
               'rss_mib_per_process': [rss_max[pid] for pid in groups],
               'probe_cores': cpu[probe.pid], 'probe': report,
               'load_average': os.getloadavg()}
    if observers:
        figures['observers'] = {child.name: {'cores': cpu[child.pid],
                                             'rss_mib': rss_max[child.pid]}
                                for child in observers}
    figures['t_start_ns'], figures['t_end_ns'] = (int(start * 1e9), int((start + wall) * 1e9))
    return figures


def start_observers(setup, children, directory):
    bridge = children.start('rerun_bridge', [
        str(BIN / 'rerun_bridge'), '--ros-args', '-p', f'facade_file:={setup.facade}',
        '-p', 'viewer:=none', '-p', f'rrd_path:={directory / "observed.rrd"}'],
        setup.env, directory / 'rerun_bridge.log')
    recorder = children.start('bag_recorder', [
        str(BIN / 'bag_recorder'), '--ros-args', '-p', f'output:={directory / "bag"}'],
        setup.env, directory / 'bag_recorder.log')
    return [bridge, recorder]


def wait_observers(observers, timeout_s):
    """Wait for each observer's start-up log line; True, or the reason it did not come."""
    ready = {'rerun_bridge': 'logging', 'bag_recorder': 'recording'}
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        waiting = []
        for child in observers:
            if not child.alive():
                return f'{child.name} exited: {child.log_tail()}'
            if ready[child.name] not in child.log_path.read_text(errors='replace'):
                waiting.append(child.name)
        if not waiting:
            time.sleep(3.0)  # their discovery of every panel's topics
            return True
        time.sleep(0.5)
    return f'{", ".join(waiting)} did not start within {timeout_s:g} s'


def stop_observers(observers):
    """SIGINT the observers, wait (60 s) for their summaries; return them."""
    for child in observers:
        child.interrupt()
    summaries = {}
    for child in observers:
        child.wait_stopped(60.0)
        text = child.log_path.read_text(errors='replace')
        lines = [line.strip() for line in text.split('\n')
                 if line.startswith(f'{child.name}:') or line.strip().startswith('dropped:')]
        summary = {'lines': lines, 'stop_s': child.stop_s, 'exit_code': child.process.returncode}
        joined = ' '.join(lines)
        for key, pattern in (('meshes_per_s', r'\(([\d.]+)/s'),
                             ('lag_median_s', r'median ([\d.]+) s'),
                             ('lag_max_s', r'max ([\d.]+) s'),
                             ('messages_written', r'(\d+) of \d+ messages'),
                             ('messages_received', r'\d+ of (\d+) messages'),
                             ('messages_per_s', r'topics \(([\d.]+)/s\)'),
                             ('dropped_recorder', r'dropped: (\d+) by the recorder'),
                             ('lost_in_transport', r'(\d+) lost in transport')):
            if child.name == 'rerun_bridge' and key not in ('meshes_per_s', 'lag_median_s',
                                                            'lag_max_s'):
                continue
            if child.name == 'bag_recorder' and key in ('meshes_per_s', 'lag_median_s',
                                                        'lag_max_s'):
                continue
            found = re.search(pattern, joined)
            summary[key] = float(found.group(1)) if found else None
        summaries[child.name] = summary
        rrd = child.log_path.parent / 'observed.rrd'
        if child.name == 'rerun_bridge' and rrd.exists():
            summary['rrd_mb'] = rrd.stat().st_size / 1e6
    return summaries


def fanout(result, commander_log, callback_logs, count):
    """Match each setpoint sent to its callback: latency figures per phase."""
    import numpy as np
    bursts, burst_ends, sent = {}, {}, []
    try:
        for line in open(commander_log):
            parts = line.split()
            if line.startswith('# burst'):
                bursts[int(parts[2])], burst_ends[int(parts[2])] = int(parts[3]), int(parts[4])
            elif len(parts) == 4:
                sent.append((int(parts[0]), int(parts[1]), parts[2], float(parts[3])))
    except OSError:
        return
    received = {}
    for path in callback_logs:
        try:
            for line in open(path):
                if not line.startswith('#'):
                    t, panel_id, value = line.split()
                    received.setdefault(panel_id, []).append((int(t), float(value)))
        except OSError:
            pass
    for times in received.values():
        times.sort()
    by_panel = {}
    for burst, t, panel_id, value in sent:
        by_panel.setdefault(panel_id, []).append((t, burst, value))
    matched = []  # (burst, burst start, publish time, callback time)
    for panel_id, publishes in by_panel.items():
        callbacks = received.get(panel_id, [])
        index = 0
        publishes.sort()
        for j, (t, burst, value) in enumerate(publishes):
            before = publishes[j + 1][0] if j + 1 < len(publishes) else math.inf
            while index < len(callbacks) and callbacks[index][0] < t:
                index += 1
            for t_cb, v_cb in callbacks[index:]:
                if t_cb >= before:
                    break
                if v_cb == value or math.isnan(v_cb):
                    matched.append((burst, bursts[burst], t, t_cb))
                    break
    result['callbacks_logged'] = sum(len(v) for v in received.values())
    for name, figures in result['phases'].items():
        if name == 'rest':
            continue
        start, end = figures['t_start_ns'], figures['t_end_ns']
        in_phase = {burst for burst, t0 in bursts.items() if start <= t0 < end}
        n_sent = sum(1 for burst, *_ in sent if burst in in_phase)
        if not callback_logs:
            figures['fanout'] = {'bursts': len(in_phase), 'sent': n_sent}
            continue
        mine = [m for m in matched if m[0] in in_phase]
        from_burst = np.array([(t_cb - t0) * 1e-9 for _, t0, _, t_cb in mine])
        from_publish = np.array([(t_cb - t) * 1e-9 for _, _, t, t_cb in mine])
        complete = [max((t_cb - t0) * 1e-9 for b, t0, _, t_cb in mine if b == burst)
                    for burst in in_phase if any(m[0] == burst for m in mine)]
        p50, p99 = _percentiles_ms(from_burst)
        q50, q99 = _percentiles_ms(from_publish)
        figures['fanout'] = {
            'bursts': len(in_phase), 'sent': n_sent, 'received': len(mine),
            'lost': n_sent - len(mine), 'p50_ms': p50, 'p99_ms': p99,
            'from_publish_p50_ms': q50, 'from_publish_p99_ms': q99,
            'burst_complete_max_ms': max(complete) * 1e3 if complete else None,
            'commander_burst_ms': (float(np.mean([burst_ends[b] - bursts[b] for b in in_phase]))
                                   * 1e-6 if in_phase else None),
            'per_burst': [_burst_figures(burst, [m for m in mine if m[0] == burst],
                                         sum(1 for b, *_ in sent if b == burst))
                          for burst in sorted(in_phase)]}


def _burst_figures(burst, matched, sent):
    """One burst's fan-out: received, p50/p99/max from its start, and setpoints later than 1 s."""
    latencies = [(t_cb - t0) * 1e-9 for _, t0, _, t_cb in matched]
    p50, p99 = _percentiles_ms(latencies)
    return {'burst': burst, 'sent': sent, 'received': len(matched), 'p50_ms': p50,
            'p99_ms': p99, 'max_ms': max(latencies) * 1e3 if latencies else None,
            'later_than_1s': sum(latency > 1.0 for latency in latencies)}


# == the table ==================================================================================

def _fmt(value, spec='.2f', none='n/a'):
    return none if value is None or (isinstance(value, float) and math.isnan(value)) \
        else format(value, spec)


def rows_of(config):
    """Table rows (dicts of display strings and figures) of one configuration."""
    panels, peer = config['panels'], config.get('peer') or {}
    rows = []
    if panels.get('error') and not panels['phases']:
        return [{'N': config['count'], 'P': config['processes'], 'phase': '-',
                 'error': panels['error']}]
    for phase in PHASES:
        figures = panels['phases'].get(phase)
        if figures is None:
            continue
        peer_figures = (peer.get('phases') or {}).get(phase)
        probe = figures['probe']
        states = [entry.get('panel_states', {}) for _, entry in sorted(probe['processes'].items())
                  if entry.get('panel_states', {}).get('hz') is not None]
        per_panel = probe['per_panel']
        per_panel_hz = [per_panel[s]['hz_mean'] for s in per_panel
                        if per_panel[s]['hz_mean'] is not None]
        if states:
            jitter = (max(s['jitter_p50_ms'] or 0 for s in states),
                      max(s['jitter_p99_ms'] or 0 for s in states), '')
        else:
            jitter = (per_panel['closure']['jitter_p50_ms'],
                      per_panel['closure']['jitter_p99_ms'], '*')
        tick = list(probe['tick_jitter'].values())
        fan = figures.get('fanout', {})
        row = {
            'N': config['count'], 'P': config['processes'], 'phase': phase,
            'panel_cores': figures['cores'],
            'peer_cores': peer_figures['cores'] if peer_figures else None,
            'rss_mib': figures['rss_mib'],
            'peer_rss_mib': peer_figures['rss_mib'] if peer_figures else None,
            'startup_s': panels.get('startup_s'), 'peer_startup_s': peer.get('startup_s'),
            'panel_states_hz': [s['hz'] for s in states],
            'per_panel_hz': sum(per_panel_hz) / len(per_panel_hz) if per_panel_hz else None,
            'jitter_p50_ms': jitter[0], 'jitter_p99_ms': jitter[1], 'jitter_source': (
                'panel_states' if states else 'per-panel closure'),
            'tick_jitter_p50_ms': max((t[0] or 0) * 1e3 for t in tick) if tick else None,
            'tick_jitter_p99_ms': max(t[1] * 1e3 for t in tick) if tick else None,
            'fanout_p50_ms': fan.get('p50_ms'), 'fanout_p99_ms': fan.get('p99_ms'),
            'setpoints_sent': fan.get('sent'), 'setpoints_lost': fan.get('lost'),
            'stop_s': _slowest(panels.get('stop_s')),
            'error': '; '.join(
                text for text in (panels.get('error'), panels.get('observer_error'),
                                  _unmatched(panels), _unmatched(peer, 'peer: '),
                                  peer.get('error') and f'peer: {peer["error"]}') if text),
        }
        row['ratio'] = (row['panel_cores'] / row['peer_cores']
                        if row['peer_cores'] else None)
        row['targets'] = verdict(row, jitter[2])
        row['jitter_mark'] = jitter[2]
        rows.append(row)
    return rows


def _unmatched(result, prefix=''):
    count = result.get('commander_unmatched')
    return f'{prefix}{count} setpoint topics never matched the commander' if count else None


def _slowest(stop_s):
    """Return the longest stop [s]; None if a process was killed (or none was stopped)."""
    return None if not stop_s or None in stop_s else max(stop_s)


def verdict(row, jitter_mark):
    """Which of the issue's targets this row misses ('ok' if none it applies to)."""
    short = []
    if row['N'] >= 1000 and row['P'] <= 2:
        if row['phase'] == 'rest' and row['panel_cores'] >= TARGETS['rest_cores']:
            short.append('cpu')
        if row['phase'] == 'moving' and row['panel_cores'] >= TARGETS['moving_cores']:
            short.append('cpu')
        if row['rss_mib'] >= TARGETS['rss_mib']:
            short.append('rss')
    rates = row['panel_states_hz'] or ([row['per_panel_hz']] if row['per_panel_hz'] else [])
    if not rates or any(abs(hz / NOMINAL_HZ - 1) > TARGETS['rate_tolerance'] for hz in rates):
        short.append('rate')
    if row['jitter_p99_ms'] is None or row['jitter_p99_ms'] >= TARGETS['jitter_p99_ms']:
        short.append('jitter')
    if row['phase'] != 'rest' and (row['fanout_p99_ms'] is None
                                   or row['fanout_p99_ms'] >= TARGETS['fanout_p99_ms']
                                   or row['setpoints_lost']):
        short.append('fan-out')
    return 'ok' if not short else 'SHORT: ' + ','.join(short)


HEADER = ('N', 'P', 'phase', 'panel cores', 'peer cores', 'ratio', 'RSS MiB pan/peer',
          'start s pan/peer', 'panel_states Hz', 'per-panel Hz', 'jitter p50/p99 ms',
          'tick p50/p99 ms', 'fan-out p50/p99 ms', 'lost/sent', 'stop s', 'targets')


def display(row):
    if set(row) <= {'N', 'P', 'phase', 'error'}:
        return [str(row['N']), str(row['P']), '-', *[''] * (len(HEADER) - 4),
                f'ERROR: {row["error"]}']
    lost = ('n/a' if row['setpoints_sent'] is None else
            f'{_fmt(row["setpoints_lost"], "d", "?")}/{row["setpoints_sent"]}')
    targets = row['targets'] + (f' ({row["error"]})' if row['error'] else '')
    return [str(row['N']), str(row['P']), row['phase'], _fmt(row['panel_cores']),
            _fmt(row['peer_cores']), _fmt(row['ratio'], '.1f'),
            f'{_fmt(row["rss_mib"], ".0f")}/{_fmt(row["peer_rss_mib"], ".0f", "-")}',
            f'{_fmt(row["startup_s"], ".1f")}/{_fmt(row["peer_startup_s"], ".1f", "-")}',
            '/'.join(f'{hz:.2f}' for hz in row['panel_states_hz']) or 'none',
            _fmt(row['per_panel_hz']),
            f'{_fmt(row["jitter_p50_ms"], ".1f")}/{_fmt(row["jitter_p99_ms"], ".1f")}'
            f'{row["jitter_mark"]}',
            f'{_fmt(row["tick_jitter_p50_ms"], ".1f")}/{_fmt(row["tick_jitter_p99_ms"], ".1f")}',
            f'{_fmt(row["fanout_p50_ms"], ".1f", "-")}/{_fmt(row["fanout_p99_ms"], ".1f", "-")}',
            lost, _fmt(row['stop_s'], '.2f', 'killed'), targets]


def text_table(rows):
    cells = [list(HEADER)] + [display(row) for row in rows]
    widths = [max(len(line[i]) for line in cells) for i in range(len(HEADER) - 1)]
    return '\n'.join('  '.join(cell.rjust(width) for cell, width in zip(line, widths))
                     + '  ' + line[-1] for line in cells)


def observer_lines(configs):
    """Markdown lines: the observers' figures and summaries, per configuration."""
    lines = []
    for config in configs:
        panels = config['panels']
        observed = panels['phases'].get('observed')
        if not (panels.get('observers') or panels.get('observer_error')):
            continue
        lines.append(f'- **{config["count"]} panels, {config["processes"]} process(es)**'
                     + (f': {panels["observer_error"]}' if panels.get('observer_error') else ''))
        for name, summary in (panels.get('observers') or {}).items():
            usage = (observed or {}).get('observers', {}).get(name, {})
            rates = ((observed or {}).get('probe') or {}).get('bridge') \
                if name == 'rerun_bridge' else None
            in_window = (f'in the window {_fmt(rates["facade_meshes_per_s"], ".1f")} facade '
                         f'meshes/s ({_fmt(rates["panels_remeshed_per_s"], ".0f")} panels '
                         're-meshed/s); ') if rates else ''
            lines.append(f'  - `{name}`: {_fmt(usage.get("cores"))} cores, '
                         f'{_fmt(usage.get("rss_mib"), ".0f")} MiB; {in_window}stop '
                         f'{_fmt(summary.get("stop_s"), ".1f", "killed")} s; '
                         + ' / '.join(f'`{line}`' for line in summary['lines']))
    return ['', '## Observers (phase `observed`)', '', *lines] if lines else []


def markdown(rows, machine, options, configs=()):
    lines = ['# Graph at scale (`bench/bench_graph.py`)', '',
             f'Run {machine["date"]} on {machine["nproc"]} cores (load average at start '
             f'{", ".join(f"{x:.2f}" for x in machine["load_average_start"])}), commit '
             f'`{machine["git_commit"][:12]}`'
             f'{" with local changes" if machine["git_dirty"] else ""}; windows of '
             f'{options["window"]:g} s after {options["settle"]:g} s; command: '
             f'`{machine["command"]}`.', '',
             f'Targets (from the issue; figures, not assertions): {TARGETS_TEXT}.', '',
             '| ' + ' | '.join(HEADER) + ' |', '|' + '---|' * len(HEADER)]
    lines += ['| ' + ' | '.join(cell.replace('|', '/') for cell in display(row)) + ' |'
              for row in rows]
    burst = ('one `/facade/setpoints` message, as the coordinator sends, timed where each '
             'panel takes its entry' if options.get('setpoints', 'panel') == 'facade'
             else "one `Float64` on each panel's own `setpoint`")
    lines += ['', 'Cores: CPU seconds (utime+stime of the processes) per wall second; RSS: '
              'the largest sum of VmRSS in the window. Jitter: p50/p99 of |arrival interval - '
              "0.1 s| of `/facade/panel_states` per process, as the probe's middleware received "
              'it (`*`: of the sampled '
              "panels' `closure`, where no process publishes `panel_states`); tick: what the "
              'processes report in `/diagnostics`. Fan-out: commander burst start to each '
              f"panel's setpoint callback; a burst is {burst}. Per-panel Hz: mean over a sample "
              'of up to 50 panels of joint_states, pressure, closure. Every figure: the JSON '
              'next to this file.']
    loads = [figures['load_average'][0] for config in configs
             for kind in ('panels', 'peer') for figures in
             ((config.get(kind) or {}).get('phases') or {}).values()]
    if loads:
        lines += ['', f'Load average (1 min) during the windows: {min(loads):.1f} to '
                  f'{max(loads):.1f} on {machine["nproc"]} cores.']
    lines += observer_lines(configs)
    return '\n'.join(lines) + '\n'


# == main =======================================================================================

def machine_info(argv):
    def git(*args):
        try:
            return subprocess.run(['git', *args], cwd=ROOT, capture_output=True, text=True,
                                  timeout=10).stdout.strip()
        except (OSError, subprocess.TimeoutExpired):
            return ''
    status = git('status', '--porcelain')
    return {'date': time.strftime('%Y-%m-%d %H:%M:%S %z'), 'nproc': os.cpu_count(),
            'load_average_start': os.getloadavg(), 'platform': platform.platform(),
            'python': platform.python_version(), 'git_commit': git('rev-parse', 'HEAD'),
            'git_dirty': bool(status), 'git_status': status.split('\n') if status else [],
            'panel_nodes_publish_panel_states': panels_publish_states(),
            'rmw': os.environ.get('RMW_IMPLEMENTATION', 'default (rmw_fastrtps_cpp)'),
            'command': ' '.join(['python', 'bench/bench_graph.py', *argv])}


def _int_list(text):
    return [int(part) for part in text.split(',') if part.strip()]


def parse(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true',
                        help='CI smoke: N=36, P=1, 5 s windows, no observers (< ~60 s)')
    parser.add_argument('--counts', type=_int_list, help='panel counts (36,200,500,1000)')
    parser.add_argument('--processes', type=_int_list, help='panel processes (1,2)')
    parser.add_argument('--json', type=Path, help='JSON path (the .md goes next to it)')
    parser.add_argument('--window', type=float, help='measurement window [s] (20; quick 5)')
    parser.add_argument('--settle', type=float, help='settle before a window [s] (5; quick 2)')
    parser.add_argument('--startup-timeout', type=float, default=180.0)
    parser.add_argument('--no-observers', dest='observers', action='store_false', default=None,
                        help='leave out the observed phase (rerun_bridge, bag_recorder)')
    parser.add_argument('--no-peer', dest='peer', action='store_false',
                        help='leave out the trivial rclpy peer')
    parser.add_argument('--domain', type=int, default=60,
                        help='first ROS_DOMAIN_ID; each measurement takes the next')
    parser.add_argument('--keep', action='store_true', help='keep the temporary directory')
    parser.add_argument('--setpoints', choices=SETPOINT_MODES, default='facade',
                        help='how the commander sends: one /facade/setpoints message per '
                             'burst, as the coordinator does (facade), or one Float64 per '
                             "panel's /facade/<id>/setpoint (panel)")
    options = parser.parse_args(argv)
    quick = options.quick
    options.counts = options.counts or ([36] if quick else [36, 200, 500, 1000])
    options.processes = options.processes or ([1] if quick else [1, 2])
    options.window = options.window or (5.0 if quick else 20.0)
    options.settle = options.settle if options.settle is not None else (2.0 if quick else 5.0)
    if options.observers is None:
        options.observers = not quick
    options.json = options.json or RESULTS / ('graph_quick.json' if quick else 'graph.json')
    return options


def main(argv):
    options = parse(argv)
    machine = machine_info(argv)
    log(f'== graph at scale: N {options.counts}, P {options.processes}, {options.window:g} s '
        f'windows; {machine["nproc"]} cores, load {os.getloadavg()[0]:.2f} ==')
    log(f'targets: {TARGETS_TEXT}')
    KERNELS.start()
    base = tempfile.mkdtemp(prefix='bench_graph_')
    configs, domain, failed = [], options.domain, False
    try:
        for count in options.counts:
            for processes in options.processes:
                if processes > count:
                    continue
                log(f'-- {count} panels in {processes} process(es) --')
                directory = Path(base) / f'n{count}_p{processes}'
                directory.mkdir()
                setup = Setup(options, count, processes, domain, directory)
                config = {'count': len(setup.ids), 'processes': processes,
                          'grid': list(grid_for(count)), 'domain': domain}
                for kind in ('panels', 'peer') if options.peer else ('panels',):
                    setup.env['ROS_DOMAIN_ID'] = str(domain)
                    domain = 60 + (domain - 60 + 1) % 40
                    children = Children()
                    try:
                        config[kind] = measure(setup, kind, children)
                    finally:
                        children.close()
                    if config[kind].get('error'):
                        log(f'  {kind}: {config[kind]["error"]}')
                wrapped = config['panels'].get('setpoint_callbacks_wrapped')
                expected = ([1] * processes if options.setpoints == 'facade'
                            else [len(s) for s in setup.slices])
                if wrapped is not None and wrapped != expected:
                    failed = True
                    log(f'  FAILED: the wrapper timed {wrapped} setpoint callbacks, not '
                        f'{expected}: no fan-out figure')
                config['rows'] = rows_of(config)
                configs.append(config)
                for row in config['rows']:
                    log('  ' + ' '.join(f'{h}={c}' for h, c in zip(HEADER[2:], display(row)[2:])))
                write(options, machine, configs)
    finally:
        if options.keep:
            log(f'temporary files: {base}')
        else:
            shutil.rmtree(base, ignore_errors=True)
    rows = [row for config in configs for row in config['rows']]
    print('\n' + text_table(rows), flush=True)
    print(f'\ntargets: {TARGETS_TEXT}', flush=True)
    log(f'written: {options.json} and {options.json.with_suffix(".md")}')
    return 1 if failed or any(config['panels'].get('error') for config in configs) else 0


def write(options, machine, configs):
    options.json.parent.mkdir(parents=True, exist_ok=True)
    rows = [row for config in configs for row in config['rows']]
    record = {'machine': machine, 'targets': TARGETS, 'nominal_hz': NOMINAL_HZ,
              'options': {key: (str(value) if isinstance(value, Path) else value)
                          for key, value in vars(options).items()},
              'rows': rows, 'configs': configs}
    options.json.write_text(json.dumps(record, indent=1, default=str) + '\n')
    options.json.with_suffix('.md').write_text(markdown(rows, machine, record['options'], configs))


if __name__ == '__main__':
    roles = {'_probe': probe_main, '_commander': commander_main, '_peer': peer_main}
    if len(sys.argv) > 1 and sys.argv[1] in roles:
        roles[sys.argv[1]](sys.argv[2:])
    else:
        signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
        sys.exit(main(sys.argv[1:]))
