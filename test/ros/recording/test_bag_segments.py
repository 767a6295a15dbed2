"""Tests of the rotated MCAP bag writer and the replay readers (no ROS needed)."""

import errno
import math
import os
from pathlib import Path
import subprocess
import sys
import textwrap

import pytest
from rosbags.highlevel import AnyReader
from rosbags.interfaces import QosDurability, QosReliability
from rosbags.rosbag2 import Reader, Writer
from rosbags.typesys import get_typestore, Stores
from ruamel.yaml import YAML

from flectofold_ros import recording
from flectofold_ros.recording import (bag_topics, BagError, read_messages,
                                      SegmentedBagWriter)

TS = get_typestore(Stores.ROS2_JAZZY)
FLOAT = 'std_msgs/msg/Float64'
PRESSURE = 'sensor_msgs/msg/FluidPressure'
STRING = 'std_msgs/msg/String'
REPO = Path(__file__).resolve().parents[3]


def cdr_float(value):
    return TS.serialize_cdr(TS.types[FLOAT](data=float(value)), FLOAT).tobytes()


def cdr_pressure(pa):
    header = TS.types['std_msgs/msg/Header'](
        stamp=TS.types['builtin_interfaces/msg/Time'](sec=1, nanosec=2), frame_id='panel_03')
    msg = TS.types[PRESSURE](header=header, fluid_pressure=float(pa), variance=0.0)
    return TS.serialize_cdr(msg, PRESSURE).tobytes()


def cdr_string(text):
    return TS.serialize_cdr(TS.types[STRING](data=text), STRING).tobytes()


def record_mixed(path, n=300, **rotation):
    """Record n Float64, n FluidPressure and one latched String message at 10 ms steps."""
    with SegmentedBagWriter(path, **rotation) as writer:
        writer.add_topic('/setpoint', FLOAT)
        writer.add_topic('/pressure', PRESSURE)
        writer.add_topic('/mode', STRING, latched=True)
        writer.write('/mode', 0, cdr_string('auto'))
        for i in range(n):
            writer.write('/setpoint', 10_000_000 * (i + 1), cdr_float(i / 10))
            writer.write('/pressure', 10_000_000 * (i + 1) + 1, cdr_pressure(1000 + i))
    return writer


def metadata(path):
    return YAML(typ='safe').load((path / 'metadata.yaml').read_text())[
        'rosbag2_bagfile_information']


def reader_counts(path):
    with Reader(path) as reader:
        counts = {}
        for conn, _, _ in reader.messages():
            counts[conn.topic] = counts.get(conn.topic, 0) + 1
        return counts, reader.message_count


def test_counts_and_values_round_trip(tmp_path):
    bag = tmp_path / 'run'
    writer = record_mixed(bag, n=50)
    assert writer.message_counts == {'/setpoint': 50, '/pressure': 50, '/mode': 1}
    assert writer.message_count == 101
    assert writer.segments == [bag / 'run_0.mcap']
    counts, total = reader_counts(bag)
    assert counts == writer.message_counts
    assert total == 101
    with AnyReader([bag], default_typestore=TS) as reader:
        values = {}
        for conn, t_ns, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            values.setdefault(conn.topic, []).append((t_ns, msg))
    assert [m.data for _, m in values['/setpoint']] == [i / 10 for i in range(50)]
    assert [m.fluid_pressure for _, m in values['/pressure']] == [1000.0 + i for i in range(50)]
    assert values['/pressure'][0][1].header.frame_id == 'panel_03'
    assert values['/mode'] == [(0, values['/mode'][0][1])]
    assert values['/mode'][0][1].data == 'auto'


def test_size_rotation_lists_every_segment(tmp_path):
    bag = tmp_path / 'big'
    writer = record_mixed(bag, n=400, max_segment_bytes=4000)
    info = metadata(bag)
    names = [f'big_{i}.mcap' for i in range(len(writer.segments))]
    assert len(names) >= 5
    assert info['version'] == 9
    assert info['storage_identifier'] == 'mcap'
    assert info['relative_file_paths'] == names
    assert [f['path'] for f in info['files']] == names
    assert sum(f['message_count'] for f in info['files']) == 801
    assert info['message_count'] == 801
    assert {t['topic_metadata']['name']: t['message_count']
            for t in info['topics_with_message_count']} == writer.message_counts
    assert sorted(p.name for p in bag.iterdir()) == sorted(names + ['metadata.yaml'])
    for segment in writer.segments:      # limit, one message and 5.8 kB of definitions
        assert segment.stat().st_size < 4000 + 100 + 6000
    counts, total = reader_counts(bag)
    assert counts == {'/setpoint': 400, '/pressure': 400, '/mode': 1}
    assert total == 801
    payload = len(cdr_string('auto')) + 400 * (len(cdr_float(0)) + len(cdr_pressure(0)))
    assert writer.bytes_written == payload + 801 * recording.MCAP_MESSAGE_OVERHEAD


def test_size_rotation_at_limit(tmp_path):
    bag = tmp_path / 'exact'
    size = len(cdr_float(0)) + recording.MCAP_MESSAGE_OVERHEAD
    with SegmentedBagWriter(bag, max_segment_bytes=10 * size) as writer:
        writer.add_topic('/setpoint', FLOAT)
        for i in range(45):
            writer.write('/setpoint', i, cdr_float(i))
    assert [f['message_count'] for f in metadata(bag)['files']] == [10, 10, 10, 10, 5]
    assert [raw for *_, raw in read_messages(bag)] == [cdr_float(i) for i in range(45)]


def test_duration_rotation(tmp_path):
    bag = tmp_path / 'timed'
    with SegmentedBagWriter(bag, max_segment_s=1.0) as writer:
        writer.add_topic('/setpoint', FLOAT)
        for i in range(35):                       # 0.0 s ... 3.4 s in 0.1 s steps
            writer.write('/setpoint', 100_000_000 * i, cdr_float(i))
    info = metadata(bag)
    assert [f['message_count'] for f in info['files']] == [10, 10, 10, 5]
    assert [f['starting_time']['nanoseconds_since_epoch'] for f in info['files']] == [
        0, 1_000_000_000, 2_000_000_000, 3_000_000_000]
    assert info['files'][0]['duration']['nanoseconds'] == 900_000_000
    assert info['duration']['nanoseconds'] == 3_400_000_000
    assert [raw for *_, raw in read_messages(bag)] == [cdr_float(i) for i in range(35)]


def test_latched_qos_recorded(tmp_path):
    bag = tmp_path / 'qos'
    record_mixed(bag, n=3, max_segment_bytes=100)
    with Reader(bag) as reader:
        qos = {conn.topic: conn.ext.offered_qos_profiles for conn in reader.connections}
    assert qos['/mode'][0].durability == QosDurability.TRANSIENT_LOCAL
    assert qos['/setpoint'][0].durability == QosDurability.VOLATILE
    assert all(p[0].reliability == QosReliability.RELIABLE and p[0].depth == 10
               for p in qos.values())
    # each segment (read on its own) carries the same QoS
    with Reader(bag / 'qos_2.mcap') as reader:
        assert {c.topic: c.ext.offered_qos_profiles for c in reader.connections} == qos
    assert bag_topics(bag) == {'/setpoint': (FLOAT, False), '/pressure': (PRESSURE, False),
                               '/mode': (STRING, True)}


CRASHING_RECORDER = textwrap.dedent("""
    import os, sys
    sys.path.insert(0, sys.argv[2])
    from rosbags.typesys import get_typestore, Stores
    from flectofold_ros.recording import SegmentedBagWriter
    ts = get_typestore(Stores.ROS2_JAZZY)
    writer = SegmentedBagWriter(sys.argv[1], max_segment_s=1.0)
    writer.add_topic('/setpoint', 'std_msgs/msg/Float64')
    writer.add_topic('/mode', 'std_msgs/msg/String', latched=True)
    writer.write('/mode', 0, ts.serialize_cdr(ts.types['std_msgs/msg/String']('x' * 40000),
                                              'std_msgs/msg/String'))
    for i in range(350):                       # 0.01 s steps: segments of 100 messages
        msg = ts.types['std_msgs/msg/Float64'](float(i))
        writer.write('/setpoint', 10_000_000 * i, ts.serialize_cdr(msg, 'std_msgs/msg/Float64'))
    print(len(writer.segments), flush=True)
    os._exit(1)
""")


def test_hard_kill_keeps_closed_segments(tmp_path):
    bag = tmp_path / 'crashed'
    done = subprocess.run([sys.executable, '-c', CRASHING_RECORDER, str(bag), str(REPO)],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 1, done.stderr
    assert done.stdout.split() == ['3']
    assert (bag / recording.WORKING_DIR).is_dir()      # the open segment was lost
    counts, total = reader_counts(bag)
    assert counts == {'/setpoint': 300, '/mode': 1}
    assert total == 301
    with AnyReader([bag], default_typestore=TS) as reader:
        values = [reader.deserialize(raw, conn.msgtype).data
                  for conn, _, raw in reader.messages() if conn.topic == '/setpoint']
    assert values == [float(i) for i in range(300)]
    assert bag_topics(bag)['/mode'] == (STRING, True)


def test_crash_before_first_rotation_leaves_empty_readable_bag(tmp_path):
    bag = tmp_path / 'early'
    writer = SegmentedBagWriter(bag, max_segment_s=10.0)
    writer.add_topic('/setpoint', FLOAT)
    writer.write('/setpoint', 1, cdr_float(1.0))
    with Reader(bag) as reader:                  # as a kill now would leave it
        assert reader.message_count == 0
        assert reader.connections == []  # topics are listed when a segment closes
    writer.close()
    assert reader_counts(bag) == ({'/setpoint': 1}, 1)


def test_close_is_idempotent_and_drops_empty_segment(tmp_path):
    bag = tmp_path / 'tidy'
    writer = SegmentedBagWriter(bag, max_segment_bytes=10)
    writer.add_topic('/setpoint', FLOAT)
    writer.write('/setpoint', 5, cdr_float(1.0))
    writer.close()
    writer.close()
    assert writer.closed
    assert sorted(p.name for p in bag.iterdir()) == ['metadata.yaml', 'tidy_0.mcap']
    empty = tmp_path / 'empty'
    with SegmentedBagWriter(empty) as writer:
        writer.add_topic('/setpoint', FLOAT)
    assert sorted(p.name for p in empty.iterdir()) == ['metadata.yaml']
    assert metadata(empty)['relative_file_paths'] == []
    assert list(read_messages(empty)) == []


def test_write_after_close_raises(tmp_path):
    writer = SegmentedBagWriter(tmp_path / 'shut')
    writer.add_topic('/setpoint', FLOAT)
    writer.close()
    with pytest.raises(BagError, match=r'shut is closed'):
        writer.write('/setpoint', 1, cdr_float(1.0))
    with pytest.raises(BagError, match='closed'):
        writer.add_topic('/other', FLOAT)


def test_path_exists(tmp_path):
    (tmp_path / 'taken').mkdir()
    with pytest.raises(BagError, match=r'taken exists already'):
        SegmentedBagWriter(tmp_path / 'taken')


def test_parent_missing(tmp_path):
    with pytest.raises(BagError, match=r'parent directory .*nowhere is missing'):
        SegmentedBagWriter(tmp_path / 'nowhere' / 'bag')
    assert not (tmp_path / 'nowhere').exists()


def test_parent_is_a_file(tmp_path):
    (tmp_path / 'file').write_text('')
    with pytest.raises(BagError, match=r'parent directory .*file is missing'):
        SegmentedBagWriter(tmp_path / 'file' / 'bag')


def _unwritable_parent(tmp_path):
    """Return a directory in which mkdir fails, for root too.

    chmod 0o555 stops ordinary users, but root (as these tests run here) ignores directory
    permissions, so when a probe write succeeds fall back to /proc: it exists and is a
    directory, but creating anything in it fails for every user (ENOENT), which exercises the
    same error path as a read-only or full file system.
    """
    locked = tmp_path / 'locked'
    locked.mkdir()
    locked.chmod(0o555)
    try:
        (locked / 'probe').mkdir()
    except OSError:
        return locked
    (locked / 'probe').rmdir()
    return Path('/proc')


def test_unwritable_directory(tmp_path):
    parent = _unwritable_parent(tmp_path)
    bag = parent / f'flectofold_bag_{os.getpid()}'
    try:
        with pytest.raises(BagError, match=rf'cannot create bag {bag}: not writable \(.+\)'):
            SegmentedBagWriter(bag)
    finally:
        (tmp_path / 'locked').chmod(0o755)
    assert not bag.exists()


def test_os_error_while_writing_becomes_bag_error(tmp_path, monkeypatch):
    bag = tmp_path / 'full'
    writer = SegmentedBagWriter(bag, max_segment_bytes=200)
    writer.add_topic('/setpoint', FLOAT)
    for i in range(20):
        writer.write('/setpoint', i, cdr_float(i))
    assert len(writer.segments) >= 2

    def disk_full(*_):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(Writer, 'write', disk_full)
    with pytest.raises(BagError, match=r'cannot write to bag .*full: No space left on device') \
            as full:
        writer.write('/setpoint', 100, cdr_float(0))
    assert recording.out_of_room(full.value)  # the recorder's exit code NO_ROOM
    assert not recording.out_of_room(BagError('two types on one topic'))
    with pytest.raises(BagError, match=r'stopped recording after an error: .*No space left'):
        writer.write('/setpoint', 101, cdr_float(0))
    writer.close()
    # the failing write first rotated, so all 20 earlier messages are in closed segments
    assert [f['path'] for f in metadata(bag)['files']] == [p.name for p in writer.segments]
    assert reader_counts(bag) == ({'/setpoint': 20}, 20)
    assert [TS.deserialize_cdr(raw, FLOAT).data for *_, raw in read_messages(bag)] == list(
        range(20))


def test_unknown_msgtype(tmp_path):
    with SegmentedBagWriter(tmp_path / 'types') as writer:
        with pytest.raises(BagError, match=r"/x: message type 'foo_msgs/msg/Bar' is unknown"):
            writer.add_topic('/x', 'foo_msgs/msg/Bar')
        writer.add_topic('/setpoint', FLOAT)
        writer.add_topic('/setpoint', FLOAT)
        with pytest.raises(BagError, match=r'/setpoint is already recorded as std_msgs/msg/Fl'):
            writer.add_topic('/setpoint', STRING)
        with pytest.raises(BagError, match=r'topic /nope is not registered'):
            writer.write('/nope', 1, cdr_float(1))
    assert bag_topics(tmp_path / 'types') == {'/setpoint': (FLOAT, False)}


@pytest.mark.parametrize('argument', ['max_segment_bytes', 'max_segment_s'])
@pytest.mark.parametrize('value', [0, -1.0, math.nan, math.inf, True, '10', [1]])
def test_bad_rotation_values(tmp_path, argument, value):
    with pytest.raises(BagError, match=argument):
        SegmentedBagWriter(tmp_path / 'bag', **{argument: value})
    assert not (tmp_path / 'bag').exists()


def test_read_messages_filters_and_orders(tmp_path):
    bag = tmp_path / 'replay'
    with SegmentedBagWriter(bag, max_segment_bytes=150) as writer:
        writer.add_topic('/setpoint', FLOAT)
        writer.add_topic('/mode', STRING, latched=True)
        for t_ns in (10, 20, 30, 40, 15, 50, 25, 60):   # late messages make segments overlap
            writer.write('/setpoint', t_ns, cdr_float(t_ns))
        writer.write('/mode', 35, cdr_string('storm'))
    assert len(writer.segments) >= 3
    messages = list(read_messages(bag))
    assert [t for _, _, t, _ in messages] == [10, 15, 20, 25, 30, 35, 40, 50, 60]
    assert messages[5] == ('/mode', STRING, 35, cdr_string('storm'))
    only = list(read_messages(bag, topics=['/setpoint']))
    assert {topic for topic, *_ in only} == {'/setpoint'}
    assert [TS.deserialize_cdr(raw, FLOAT).data for *_, raw in only] == [
        10, 15, 20, 25, 30, 40, 50, 60]


def test_read_messages_unknown_topic(tmp_path):
    bag = tmp_path / 'replay'
    record_mixed(bag, n=2)
    with pytest.raises(BagError,
                       match=r'has no topic /missing; it has 3 topics: /mode, /pressure, /set'):
        read_messages(bag, topics=['/setpoint', '/missing'])


def test_not_a_bag(tmp_path):
    with pytest.raises(BagError, match=r'nothing does not exist'):
        list(read_messages(tmp_path / 'nothing'))
    (tmp_path / 'plain').mkdir()
    with pytest.raises(BagError, match=r'plain is not a readable rosbag2 bag'):
        bag_topics(tmp_path / 'plain')
