"""Record topics to a rosbag2 (MCAP) directory, as rclpy delivers their serialized bytes.

``ros2 run flectofold_ros bag_recorder --ros-args -p output:=day -p use_sim_time:=true``.
Topics matching ``topics`` (default everything under ``/facade``, ``/diagnostics`` and
``/clock``) are found as they appear and subscribed with ``raw=True``: the CDR bytes go to the
bag untouched, stamped with the node's ROS time (the simulated time under ``use_sim_time``).
Writing runs on its own thread behind a bounded queue; the bag rotates by size or duration and
stays valid after Ctrl-C or SIGTERM. Every ``flush_period_s`` of wall time the messages written
are handed to the operating system, so that after a SIGKILL ``bag_reindex`` recovers all but
about that last period. Every message the recorder could not keep is counted and reported.
Parameters, the bag layout and the bounds: ``msg_docs/bag_recorder.md``.
"""

from collections import Counter
from datetime import datetime
import fnmatch
import queue
import sys
import threading
import time

from rclpy.clock import Clock, ClockType
from rclpy.event_handler import SubscriptionEventCallbacks, UnsupportedEventTypeError
from rclpy.node import Node

from flectofold_ros.recording import BagError, out_of_room, SegmentedBagWriter
from flectofold_ros.runtime import diagnostics
from flectofold_ros.runtime.interfaces import message_class, offered, publisher, subscription
from flectofold_ros.runtime.parameters import declare_all, double, string, strings
from flectofold_ros.runtime.runner import NO_ROOM, Program, run_nodes
from flectofold_ros.wire import contract

QUEUE_DEPTH = 100000
#: Default rotation: a segment closes (and becomes directly readable after a SIGKILL) after
#: this much ROS time or this many MB of messages, whichever comes first.
MAX_SEGMENT_S, MAX_SEGMENT_MB = 300.0, 16.0
#: Default wall time between flushes: the bound of what ``bag_reindex`` cannot recover [s].
FLUSH_PERIOD_S = 1.0
USAGE = 'bag_recorder [--ros-args -p output:=DIR -p name:=value ...]'

#: name -> Spec.
PARAMETERS = {
    'output': string('', 'Bag directory to create (must not exist); empty: flectofold_<time> '
                     'in the working directory'),
    'topics': strings(contract.RECORDED_BY_DEFAULT, 'Topics to record: exact names, or '
                      'patterns with * (one level) and /** (everything below)'),
    'max_segment_mb': double(MAX_SEGMENT_MB, 'Start a new bag file after this many MB; 0: '
                             'never', 0.0, 1e6),
    'max_segment_s': double(MAX_SEGMENT_S, 'Start a new bag file after this much ROS time '
                            '[s]; 0: never', 0.0, 1e7),
    'flush_period_s': double(FLUSH_PERIOD_S, 'Wall time between hand-overs of the written '
                             'messages to the operating system [s]', 0.05, 60.0),
    'discovery_period_s': double(0.5, 'Wall time between looks for new topics [s]', 0.05,
                                 60.0),
    'diagnostics_period_s': double(1.0, 'Period of /diagnostics, wall clock [s]', 0.1, 60.0),
}


def check_patterns(patterns):
    """Return the topic patterns after checking each is an absolute name or pattern."""
    patterns = list(patterns)
    if not patterns:
        raise ValueError('topics is empty: give at least one topic or pattern')
    for pattern in patterns:
        if not pattern.startswith('/') or pattern.endswith('/') or '//' in pattern:
            raise ValueError(f'topic pattern {pattern!r} must be an absolute topic name such as '
                             f'/clock, /facade/*/pressure or /facade/**')
    return patterns


def topic_matches(topic, patterns):
    """Whether ``topic`` matches a pattern: ``*`` is one name level, ``/**`` all below."""
    for pattern in patterns:
        if pattern.endswith('/**') and topic.startswith(pattern[:-2]):
            return True
        if '*' in pattern and fnmatch.fnmatchcase(topic, pattern) and \
                topic.count('/') == pattern.count('/'):
            return True
        if topic == pattern:
            return True
    return False


class BagRecorder(Node):
    """Node ``bag_recorder``: subscribes as topics appear; a thread writes the bag."""

    def __init__(self, **kwargs):
        super().__init__(contract.RECORDER_NODE, **kwargs)
        declare_all(self, PARAMETERS)
        self.patterns = check_patterns(self._value('topics'))
        output = self._value('output') or \
            f'flectofold_{datetime.now().strftime("%Y%m%d_%H%M%S")}'
        self._flush_period_s = self._value('flush_period_s')
        # add_topic (executor thread) and write/flush (writer thread) share the open segment.
        self._writer_lock = threading.Lock()
        self.writer = SegmentedBagWriter(
            output, max_segment_bytes=self._value('max_segment_mb') * 1e6 or None,
            max_segment_s=self._value('max_segment_s') or None)
        self.received = Counter()
        self.dropped_queue = 0
        self.lost_in_transport = 0
        self.skipped_topics = {}
        self.error = None
        self.no_room = False
        """The write error was a full disk (or quota): the exit code says so (NO_ROOM)."""
        self._recorded = {}
        self._early = []
        self._lost_events_supported = True
        self._queue = queue.Queue(maxsize=QUEUE_DEPTH)
        self._thread = threading.Thread(target=self._write_loop, name='bag_writer', daemon=True)
        self._thread.start()
        self.started = time.monotonic()
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._diagnostics = publisher(self, contract.DIAGNOSTICS)
        self.create_timer(self._value('discovery_period_s'), self.discover, clock=steady)
        self.create_timer(self._value('diagnostics_period_s'), self._report, clock=steady)
        self.discover()

    def _value(self, name):
        return self.get_parameter(name).value

    # -- subscribing ------------------------------------------------------------------------

    def discover(self):
        """Subscribe to every new topic that matches the patterns."""
        for topic, types in self.get_topic_names_and_types():
            if topic in self._recorded or topic in self.skipped_topics or \
                    not topic_matches(topic, self.patterns):
                continue
            if len(types) != 1:
                self._skip(topic, f'published with several types: {", ".join(types)}')
                continue
            self._subscribe(topic, types[0])

    def _skip(self, topic, reason):
        self.skipped_topics[topic] = reason
        self.get_logger().error(f'not recording {topic}: {reason}')

    def _subscribe(self, topic, msgtype):
        publishers = self.get_publishers_info_by_topic(topic)
        if not publishers:
            return  # gone again; the next look will tell
        latched, reliable = offered(publishers)
        try:
            message_class(msgtype)
            with self._writer_lock:
                self.writer.add_topic(topic, msgtype, latched=latched)
        except (ValueError, BagError) as error:
            self._skip(topic, str(error))
            return
        recorded = contract.Topic(topic, msgtype, contract.recording_qos(latched, reliable))
        events = SubscriptionEventCallbacks(message_lost=self._on_lost) \
            if self._lost_events_supported else None
        try:
            self._recorded[topic] = subscription(self, recorded, self._callback(topic),
                                                 raw=True, event_callbacks=events)
        except UnsupportedEventTypeError:
            self._lost_events_supported = False
            self.get_logger().warning('this RMW does not report lost messages; only queue '
                                      'overflows can be counted')
            self._recorded[topic] = subscription(self, recorded, self._callback(topic),
                                                 raw=True)

    def _on_lost(self, info):
        self.lost_in_transport += info.total_count_change
        self.get_logger().error(f'{info.total_count_change} message(s) lost before reaching '
                                f'the recorder', throttle_duration_sec=1.0)

    def _callback(self, topic):
        def on_message(raw):
            self.received[topic] += 1
            now_ns = self.get_clock().now().nanoseconds
            if now_ns <= 0:  # use_sim_time before the first /clock: stamp with the first one
                self._early.append((topic, raw))
                return
            for early_topic, early_raw in self._early:
                self._enqueue(early_topic, now_ns, early_raw)
            self._early.clear()
            self._enqueue(topic, now_ns, raw)
        return on_message

    def _enqueue(self, topic, t_ns, raw):
        try:
            self._queue.put_nowait((topic, t_ns, raw))
        except queue.Full:
            self.dropped_queue += 1
            self.get_logger().error('the bag writer is behind: message dropped',
                                    throttle_duration_sec=1.0)

    # -- writing ----------------------------------------------------------------------------

    def _write_loop(self):
        next_flush = time.monotonic() + self._flush_period_s
        while True:
            try:
                item = self._queue.get(timeout=max(0.0, next_flush - time.monotonic()))
            except queue.Empty:
                item = ()
            if item is None:
                return
            if time.monotonic() >= next_flush:
                self._locked(self.writer.flush)
                next_flush = time.monotonic() + self._flush_period_s
            if not item:
                continue
            if self.error is not None:
                self.dropped_queue += 1
                continue
            self._locked(self.writer.write, *item)

    def _locked(self, method, *arguments):
        """Call a writer method under the lock; a BagError stops the recording."""
        if self.error is not None:
            return
        try:
            with self._writer_lock:
                method(*arguments)
        except BagError as error:
            self.error, self.no_room = str(error), out_of_room(error)

    def close(self):
        """Write what is queued (early messages too), close the bag; return its summary."""
        if self._early:
            stamp_ns = max(self.get_clock().now().nanoseconds, 1)
            for topic, raw in self._early:
                self._enqueue(topic, stamp_ns, raw)
            self._early.clear()
        self._queue.put(None)
        self._thread.join()
        try:
            with self._writer_lock:
                self.writer.close()
        except BagError as error:
            if self.error is None:
                self.error, self.no_room = str(error), out_of_room(error)
        return self.summary()

    def figures(self):
        wall_s = max(time.monotonic() - self.started, 1e-9)
        received = sum(self.received.values())
        with self._writer_lock:
            written, segments = self.writer.message_count, len(self.writer.segments)
        return {'topics': len(self._recorded), 'received': received,
                'written': written, 'messages_per_s': received / wall_s,
                'bytes_written': self.writer.bytes_written,
                'segments': segments, 'dropped_queue': self.dropped_queue,
                'lost_in_transport': self.lost_in_transport,
                'error': self.error or ''}

    def summary(self):
        f = self.figures()
        lines = [f'bag_recorder: {f["written"]} of {f["received"]} messages written from '
                 f'{f["topics"]} topics ({f["messages_per_s"]:.0f}/s), '
                 f'{f["bytes_written"] / 1e6:.1f} MB in {f["segments"]} file(s) at '
                 f'{self.writer.path}',
                 f'  dropped: {f["dropped_queue"]} by the recorder, {f["lost_in_transport"]} '
                 f'lost in transport'
                 + ('' if self._lost_events_supported else ' (not reported by this RMW)')]
        if self.error:
            lines.append(f'  ERROR: recording stopped: {self.error}')
        lines += [f'  not recorded: {topic}: {reason}'
                  for topic, reason in self.skipped_topics.items()]
        return '\n'.join(lines)

    def _report(self):
        f = self.figures()
        level = diagnostics.ERROR if f['error'] else (
            diagnostics.WARN if f['dropped_queue'] or f['lost_in_transport'] else diagnostics.OK)
        self._diagnostics.publish(diagnostics.diagnostic_array(self, [diagnostics.status(
            self, level, 'recording', contract.RECORDER_NODE,
            f['error'] or f'{f["written"]} written', f)]))


class _Recording(Program):
    """The recorder as a program: it ends on a write error; on close, the bag is closed."""

    def __init__(self):
        super().__init__([BagRecorder()])
        recorder = self.nodes[0]
        recorder.get_logger().info(f'recording {", ".join(recorder.patterns)} to '
                                   f'{recorder.writer.path}')

    def done(self):
        return self.nodes[0].error is not None

    def close(self, interrupted):
        recorder = self.nodes[0]
        print(recorder.close(), flush=True)
        if recorder.no_room:
            return NO_ROOM  # not restarted onto the same full disk
        return 1 if recorder.error else 0


def main(args=None):
    """``ros2 run flectofold_ros bag_recorder --ros-args -p output:=day``."""
    return run_nodes('bag_recorder', args, _Recording, USAGE, PARAMETERS,
                     bad_input=(BagError,))


if __name__ == '__main__':
    sys.exit(main())
