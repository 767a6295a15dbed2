"""Record topics to a rosbag2 (MCAP) directory, as rclpy delivers their serialized bytes.

``ros2 run flectofold_ros bag_recorder --ros-args -p output:=day -p use_sim_time:=true``.
Topics matching ``topics`` (default everything under ``/facade``, ``/diagnostics`` and
``/clock``) are found as they appear and subscribed with ``raw=True``: the CDR bytes go to the
bag untouched, stamped with the node's ROS time (the simulated time under ``use_sim_time``).
Writing runs on its own thread behind a bounded queue; the bag rotates by size or duration and
stays valid after Ctrl-C or SIGTERM. Every message the recorder could not keep is counted and
reported. Parameters and the bag layout: ``msg_docs/bag_recorder.md``.
"""

from collections import Counter
from datetime import datetime
import fnmatch
import queue
import sys
import threading
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.event_handler import SubscriptionEventCallbacks, UnsupportedEventTypeError
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from flectofold_ros.bag_segments import BagError, SegmentedBagWriter
from flectofold_ros.diagnostics import diagnostic_array
from flectofold_ros.message_types import message_class
from flectofold_ros.parameters import declare_all, double, string, strings
from flectofold_ros.spinning import make_executor, print_usage_if_asked, spin_until

DEFAULT_TOPICS = ['/facade/**', '/diagnostics', '/clock']
QUEUE_DEPTH = 100000
SUBSCRIPTION_DEPTH = 1000

PARAMETERS = {
    'output': ('', string('Bag directory to create (must not exist); empty: '
                          'flectofold_<time> in the working directory')),
    'topics': (DEFAULT_TOPICS, strings(
        'Topics to record: exact names, or patterns with * (one level) and /** (everything '
        'below)')),
    'max_segment_mb': (256.0, double('Start a new bag file after this many MB; 0: never',
                                     0.0, 1e6)),
    'max_segment_s': (0.0, double('Start a new bag file after this much ROS time [s]; '
                                  '0: never', 0.0, 1e7)),
    'discovery_period_s': (0.5, double('Wall time between looks for new topics [s]',
                                       0.05, 60.0)),
    'diagnostics_period_s': (1.0, double('Period of /diagnostics, wall clock [s]', 0.1, 60.0)),
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
        super().__init__('bag_recorder', **kwargs)
        declare_all(self, PARAMETERS)
        self.patterns = check_patterns(self._value('topics'))
        output = self._value('output') or \
            f'flectofold_{datetime.now().strftime("%Y%m%d_%H%M%S")}'
        self.writer = SegmentedBagWriter(
            output, max_segment_bytes=self._value('max_segment_mb') * 1e6 or None,
            max_segment_s=self._value('max_segment_s') or None)
        self.received = Counter()
        self.dropped_queue = 0
        self.lost_in_transport = 0
        self.skipped_topics = {}
        self.error = None
        self._recorded = {}
        self._early = []
        self._lost_events_supported = True
        self._queue = queue.Queue(maxsize=QUEUE_DEPTH)
        self._thread = threading.Thread(target=self._write_loop, name='bag_writer', daemon=True)
        self._thread.start()
        self.started = time.monotonic()
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._diagnostics = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
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
        latched = all(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
                      for p in publishers)
        reliable = all(p.qos_profile.reliability == ReliabilityPolicy.RELIABLE
                       for p in publishers)
        try:
            cls = message_class(msgtype)
            self.writer.add_topic(topic, msgtype, latched=latched)
        except (ValueError, BagError) as error:
            self._skip(topic, str(error))
            return
        qos = QoSProfile(
            depth=SUBSCRIPTION_DEPTH,
            durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
            reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT)
        events = SubscriptionEventCallbacks(message_lost=self._on_lost) \
            if self._lost_events_supported else None
        try:
            self._recorded[topic] = self.create_subscription(
                cls, topic, self._callback(topic), qos, raw=True, event_callbacks=events)
        except UnsupportedEventTypeError:
            self._lost_events_supported = False
            self.get_logger().warning('this RMW does not report lost messages; only queue '
                                      'overflows can be counted')
            self._recorded[topic] = self.create_subscription(
                cls, topic, self._callback(topic), qos, raw=True)

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
        while True:
            item = self._queue.get()
            if item is None:
                return
            if self.error is not None:
                self.dropped_queue += 1
                continue
            try:
                self.writer.write(*item)
            except BagError as error:
                self.error = str(error)

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
            self.writer.close()
        except BagError as error:
            self.error = self.error or str(error)
        return self.summary()

    def figures(self):
        wall_s = max(time.monotonic() - self.started, 1e-9)
        received = sum(self.received.values())
        return {'topics': len(self._recorded), 'received': received,
                'written': self.writer.message_count, 'messages_per_s': received / wall_s,
                'bytes_written': self.writer.bytes_written,
                'segments': len(self.writer.segments), 'dropped_queue': self.dropped_queue,
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
        level = DiagnosticStatus.ERROR if f['error'] else (
            DiagnosticStatus.WARN if f['dropped_queue'] or f['lost_in_transport']
            else DiagnosticStatus.OK)
        self._diagnostics.publish(diagnostic_array(
            self, level, 'recording', 'bag_recorder', f['error'] or f'{f["written"]} written',
            f))


def main(args=None):
    if print_usage_if_asked(args, 'bag_recorder [--ros-args -p output:=DIR -p ...]',
                            PARAMETERS):
        return 0
    rclpy.init(args=args)
    executor = make_executor()
    recorder = None
    try:
        recorder = BagRecorder()
        executor.add_node(recorder)
        recorder.get_logger().info(f'recording {", ".join(recorder.patterns)} to '
                                   f'{recorder.writer.path}')
        spin_until(executor, lambda: recorder.error is not None)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (BagError, ValueError, ParameterException) as error:
        print(f'bag_recorder: {error}', file=sys.stderr)
        return 2
    finally:
        if recorder is not None:
            print(recorder.close(), flush=True)
            recorder.destroy_node()
        rclpy.try_shutdown()
    return 1 if recorder.error else 0


if __name__ == '__main__':
    sys.exit(main())
