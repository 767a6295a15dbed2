"""Every way a real bag_recorder can end, read back with rosbags and the mcap library.

A probe node publishes Float64 0, 1, 2, ... at about 250 Hz; the recorder is stopped as a
terminal (SIGINT to the group), a service manager (SIGTERM, then SIGKILL after a grace) or a
crash (SIGKILL) stops it. After a signal the bag must be complete; after SIGKILL everything
but the documented bounds must be readable directly, and after ``bag_reindex`` all but the
last flush period (msg_docs/bag_recorder.md).
"""

from pathlib import Path
import re
import signal
import subprocess
import time

from mcap.reader import make_reader
import pytest
from ros_graph import BIN, domain_for, Graph, PROMPT_S
from rosbags.rosbag2 import Reader
from rosbags.typesys import get_typestore, Stores
from ruamel.yaml import YAML
from std_msgs.msg import Float64

from flectofold_ros.nodes.bag_recorder import FLUSH_PERIOD_S
from flectofold_ros.recording import check_bag
from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.wire import contract

pytestmark = pytest.mark.graph
TOPIC = contract.Topic('/test/count', 'std_msgs/msg/Float64')
TS = get_typestore(Stores.ROS2_JAZZY)
#: Messages the probe publishes per second of wall time [1/s].
RATE_HZ = 250.0
#: Slack on top of a documented bound for the recorder's queue and writer thread on a loaded
#: machine [s]. The bounds are taken on the recorder's own receive stamps (the bag's): what the
#: middleware had not delivered yet when it was killed is no part of them.
SLACK_S = 1.0


class Counting:
    """The probe's publisher of 0, 1, 2, ... and the wall time each was published at."""

    def __init__(self, graph):
        self.graph = graph
        self.publisher = publisher(graph.node, TOPIC)
        self.stamps_s = []
        self.recorder_received = 0  # the recorder's count of messages taken, by /diagnostics
        subscription(graph.node, contract.DIAGNOSTICS, self._on_diagnostics)

    def _on_diagnostics(self, message):
        for status in message.status:
            if status.hardware_id == contract.RECORDER_NODE:
                figures = {item.key: item.value for item in status.values}
                self.recorder_received = int(figures['received'])

    def wait_for_recorder(self):
        assert self.graph.spin_until(lambda: self.publisher.get_subscription_count() >= 1,
                                     30.0), 'the recorder never subscribed'
        self.graph.spin_for(0.5)

    def publish_for(self, duration_s, rate_hz=RATE_HZ):
        """Publish at ``rate_hz`` for ``duration_s`` [s of wall time], spinning in between."""
        start = time.monotonic()
        due = len(self.stamps_s)
        while (now := time.monotonic()) < start + duration_s:
            while len(self.stamps_s) < due + (now - start) * rate_hz:
                self.publisher.publish(Float64(data=float(len(self.stamps_s))))
                self.stamps_s.append(time.monotonic())
            self.graph.executor.spin_once(timeout_sec=0.002)

    def wait_until_recorded(self):
        """Spin until the recorder says it took every message published."""
        assert self.graph.spin_until(
            lambda: self.recorder_received >= len(self.stamps_s), 30.0), \
            (self.recorder_received, len(self.stamps_s))


@pytest.fixture
def graph():
    graph = Graph(domain_for(14), name='endings_probe')
    yield graph
    graph.close()


def start_recorder(graph, bag, *parameters):
    process = graph.start('bag_recorder', '--ros-args', '-p', f'output:={bag}',
                          '-p', f'topics:=[{TOPIC.name}]', *parameters, group=True)
    counting = Counting(graph)
    counting.wait_for_recorder()
    return process, counting


def stop_within_bound(process, *signals, gap_s=0.0):
    """Send ``signals`` to the whole group; return exit code, output, seconds to exit."""
    started = time.monotonic()
    for number in signals:
        Graph.signal_group(process, number)
        time.sleep(gap_s)
    output, _ = process.communicate(timeout=60)
    return process.returncode, output, time.monotonic() - started


def kill_group(process):
    """SIGKILL the group; return the system time of the kill [ns] (the recorder's ROS time)."""
    killed_ns = time.time_ns()
    Graph.signal_group(process, signal.SIGKILL)
    process.communicate(timeout=30)
    return killed_ns


def recorded_values(bag):
    """Values of the topic as rosbags reads the bag directory, in time order."""
    return [value for value, _ in recorded(bag)]


def recorded(bag):
    """(value, receive stamp [ns]) of the topic's messages in the bag directory, in time order."""
    with Reader(bag) as reader:
        conns = [c for c in reader.connections if c.topic == TOPIC.name]
        messages = [(int(TS.deserialize_cdr(raw, TOPIC.msgtype).data), t_ns)
                    for _, t_ns, raw in reader.messages(connections=conns)]
        assert reader.message_count == len(messages)
    return messages


def seconds_before(killed_ns, bag, index):
    """Seconds from the recorder's receipt of message ``index`` (in ``bag``) to the kill."""
    return (killed_ns - recorded(bag)[index][1]) * 1e-9


def assert_readers_agree(bag):
    """metadata.yaml, rosbags and the mcap library count the same messages per file."""
    info = YAML(typ='safe').load((bag / 'metadata.yaml').read_text())[
        'rosbag2_bagfile_information']
    listed = {Path(f['path']).name: f['message_count'] for f in info['files']}
    read = {}
    for name in listed:
        with (bag / name).open('rb') as stream:
            reader = make_reader(stream)
            read[name] = sum(1 for _ in reader.iter_messages())
            assert reader.get_summary().statistics.message_count == read[name], name
    assert read == listed
    assert sum(listed.values()) == info['message_count'] == len(recorded_values(bag))


def assert_prefix(values):
    """Check the values are 0, 1, ... without gap or repetition; return how many."""
    assert values == list(range(len(values)))
    return len(values)


def reindex(bag):
    done = subprocess.run([str(BIN / 'bag_reindex'), str(bag)], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM])
def test_a_signal_to_the_group_keeps_every_message(graph, tmp_path, sig):
    process, counting = start_recorder(graph, tmp_path / 'bag')
    counting.publish_for(2.0)
    counting.wait_until_recorded()                 # the recorder takes the last ones
    code, output, stop_s = stop_within_bound(process, sig)
    assert code == 0, output
    assert stop_s < PROMPT_S, output
    assert check_bag(tmp_path / 'bag').complete, check_bag(tmp_path / 'bag').summary()
    assert assert_prefix(recorded_values(tmp_path / 'bag')) == len(counting.stamps_s) >= 400
    assert_readers_agree(tmp_path / 'bag')
    assert f'{len(counting.stamps_s)} of {len(counting.stamps_s)} messages written' in output


def test_a_second_signal_while_closing_cannot_cut_the_close_short(graph, tmp_path):
    process, counting = start_recorder(graph, tmp_path / 'bag')
    counting.publish_for(2.0)
    counting.wait_until_recorded()
    # the terminal's Ctrl-C, a parent passing it on, then a service manager's SIGTERM
    code, output, stop_s = stop_within_bound(
        process, signal.SIGINT, signal.SIGINT, signal.SIGTERM, gap_s=0.02)
    assert code == 0 and 'Traceback' not in output, output
    assert stop_s < PROMPT_S, output
    assert check_bag(tmp_path / 'bag').complete, check_bag(tmp_path / 'bag').summary()
    assert assert_prefix(recorded_values(tmp_path / 'bag')) == len(counting.stamps_s)
    assert_readers_agree(tmp_path / 'bag')


def test_after_sigkill_all_but_the_open_segment_is_readable_and_reindex_recovers_it(
        graph, tmp_path):
    segment_s = 1.0
    bag = tmp_path / 'bag'
    process, counting = start_recorder(graph, bag, '-p', f'max_segment_s:={segment_s}')
    counting.publish_for(4.0)
    killed_ns = kill_group(process)               # while it records
    assert not check_bag(bag).complete
    direct = assert_prefix(recorded_values(bag))
    assert direct > 0
    assert_readers_agree(bag)
    report = reindex(bag)
    recovered = assert_prefix(recorded_values(bag))
    assert recovered > direct, report
    # not directly readable: the open segment (at most segment_s of ROS time, here wall time)
    assert seconds_before(killed_ns, bag, direct) <= segment_s + SLACK_S, report
    assert seconds_before(killed_ns, bag, recovered - 1) <= FLUSH_PERIOD_S + SLACK_S, report
    assert check_bag(bag).complete, check_bag(bag).summary()
    assert_readers_agree(bag)


def test_after_sigkill_with_the_default_rotation_reindex_recovers_all_but_the_tail(
        graph, tmp_path):
    bag = tmp_path / 'bag'
    process, counting = start_recorder(graph, bag)
    counting.publish_for(4.0)
    killed_ns = kill_group(process)
    check = check_bag(bag)
    assert not check.complete and check.unfinished_bytes > 0, check.summary()
    report = reindex(bag)
    recovered = assert_prefix(recorded_values(bag))
    assert re.search(rf'recovered {recovered} messages from unfinished', report), report
    assert seconds_before(killed_ns, bag, recovered - 1) <= FLUSH_PERIOD_S + SLACK_S, report
    assert check_bag(bag).complete
    assert_readers_agree(bag)


@pytest.mark.parametrize('grace_s', [0.0, 0.05])
def test_sigterm_then_sigkill_after_a_short_grace_leaves_a_recoverable_bag(
        graph, tmp_path, grace_s):
    bag = tmp_path / 'bag'
    process, counting = start_recorder(graph, bag, '-p', 'max_segment_s:=1.0')
    counting.publish_for(3.0)
    Graph.signal_group(process, signal.SIGTERM)
    counting.publish_for(grace_s)
    killed_ns = kill_group(process)               # as a service manager whose grace ran out
    report = reindex(bag)
    recovered = assert_prefix(recorded_values(bag))
    assert seconds_before(killed_ns, bag, recovered - 1) <= FLUSH_PERIOD_S + SLACK_S, report
    assert check_bag(bag).complete, check_bag(bag).summary()
    assert_readers_agree(bag)


# -- the bringup: Ctrl-C in the terminal of `facade --record` --------------------------------

def test_ctrl_c_to_facade_record_leaves_a_complete_bag(tmp_path, small_facade_text):
    facade = tmp_path / 'small.yaml'
    facade.write_text(small_facade_text('shading_target: 0.9'))
    graph = Graph(domain_for(15), name='facade_probe')
    try:
        process = graph.start('facade', '--facade', str(facade), '--speedup', '360',
                              '--panel-processes', '1', '--record', '--rerun', 'none',
                              '--out', str(tmp_path / 'out'), group=True)
        head = graph.read_until(process, lambda line: '| panels reporting' in line, 240.0)
        assert head and '| panels reporting' in head[-1], ''.join(head)
        time.sleep(3.0)                           # some minutes of the simulated day
        code, output, _ = stop_within_bound(process, signal.SIGINT)
    finally:
        graph.close()
    output = ''.join(head) + output
    assert code == 130, output
    bag = (tmp_path / 'out' / 'latest' / 'bag').resolve()
    check = check_bag(bag)
    assert check.complete, check.summary() + '\n' + output
    assert check.message_counts[contract.CLOCK.name] > 0
    written = re.search(r'bag_recorder: (\d+) of (\d+) messages written', output)
    assert written and written[1] == written[2], output
    with Reader(bag) as reader:
        assert reader.message_count == check.message_count == int(written[1])
        assert sum(1 for _ in reader.messages()) == check.message_count
    assert check.files and not check.unfinished_segment
    info = YAML(typ='safe').load((bag / 'metadata.yaml').read_text())
    assert info['rosbag2_bagfile_information']['relative_file_paths'] == check.files
    total = 0
    for name in check.files:
        with (bag / name).open('rb') as stream:
            total += sum(1 for _ in make_reader(stream).iter_messages())
    assert total == check.message_count
