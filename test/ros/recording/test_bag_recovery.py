"""A hard-killed writer's bag: check_bag says so, bag_reindex recovers it (no ROS needed)."""

from pathlib import Path
import shutil
import subprocess
import sys
import textwrap

from mcap.reader import make_reader
import pytest
from rosbags.rosbag2 import Reader
from rosbags.typesys import get_typestore, Stores
from ruamel.yaml import YAML

from flectofold_ros import recording
from flectofold_ros.recording import BagError, check_bag, SegmentedBagWriter
from flectofold_ros.recording.recovery import reindex

TS = get_typestore(Stores.ROS2_JAZZY)
FLOAT = 'std_msgs/msg/Float64'
REPO = Path(__file__).resolve().parents[3]
BIN = Path(sys.executable).parent

#: Writes 1 s segments of Float64 0, 1, 2, ... at 10 ms steps, flushing every 10 messages, and
#: dies (os._exit: no close, as after SIGKILL) after message argv[3] - 1.
KILLED_WRITER = textwrap.dedent("""
    import os, sys
    sys.path.insert(0, sys.argv[2])
    from rosbags.typesys import get_typestore, Stores
    from flectofold_ros.recording import SegmentedBagWriter
    ts = get_typestore(Stores.ROS2_JAZZY)
    writer = SegmentedBagWriter(sys.argv[1], max_segment_s=1.0)
    writer.add_topic('/setpoint', 'std_msgs/msg/Float64')
    writer.add_topic('/mode', 'std_msgs/msg/String', latched=True)
    writer.write('/mode', 0, ts.serialize_cdr(ts.types['std_msgs/msg/String']('auto'),
                                              'std_msgs/msg/String'))
    for i in range(int(sys.argv[3])):
        msg = ts.types['std_msgs/msg/Float64'](float(i))
        writer.write('/setpoint', 10_000_000 * i, ts.serialize_cdr(msg, 'std_msgs/msg/Float64'))
        if i % 10 == 9:
            writer.flush()
    os._exit(1)
""")


def killed_bag(path, messages):
    done = subprocess.run([sys.executable, '-c', KILLED_WRITER, str(path), str(REPO),
                           str(messages)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 1, done.stderr
    return path


def setpoints(bag):
    """Values of /setpoint as rosbags reads the bag directory."""
    with Reader(bag) as reader:
        conns = [c for c in reader.connections if c.topic == '/setpoint']
        return sorted(TS.deserialize_cdr(raw, FLOAT).data
                      for _, _, raw in reader.messages(connections=conns))


def mcap_counts(bag):
    """Messages per file as the mcap library reads them, checked against each summary."""
    counts = {}
    for file in sorted(bag.glob('*.mcap')):
        with file.open('rb') as stream:
            reader = make_reader(stream)
            counted = sum(1 for _ in reader.iter_messages())
            assert reader.get_summary().statistics.message_count == counted, file
            counts[file.name] = counted
    return counts


def listed_counts(bag):
    info = YAML(typ='safe').load((bag / 'metadata.yaml').read_text())[
        'rosbag2_bagfile_information']
    return {Path(f['path']).name: f['message_count'] for f in info['files']}


def test_a_killed_writer_leaves_a_bag_that_check_bag_calls_incomplete(tmp_path):
    bag = killed_bag(tmp_path / 'killed', 355)
    check = check_bag(bag)
    assert not check.complete
    assert check.message_count == 301          # segments 0-2 closed: /mode and 0 ... 299
    assert check.files == ['killed_0.mcap', 'killed_1.mcap', 'killed_2.mcap']
    assert check.unfinished_segment == bag / '.open_segment' / '.open_segment.mcap'
    assert check.unfinished_bytes > 0
    assert 'INCOMPLETE' in check.summary() and f'bag_reindex {bag}' in check.summary()


def test_reindex_recovers_every_flushed_message(tmp_path):
    bag = killed_bag(tmp_path / 'killed', 355)
    assert setpoints(bag) == list(range(300))   # directly readable: the closed segments
    report = reindex(bag)
    # 300 ... 349 were flushed; 350 ... 354 were still in the chunk in memory
    assert [r.message_count for r in report.recovered] == [50]
    assert report.recovered[0].file_name == 'killed_3.mcap'
    assert report.recovered[0].source == '.open_segment/.open_segment.mcap'
    assert report.message_count == 351
    assert setpoints(bag) == list(range(350))
    assert check_bag(bag).complete, check_bag(bag).summary()
    assert mcap_counts(bag) == listed_counts(bag) == {
        'killed_0.mcap': 101, 'killed_1.mcap': 100, 'killed_2.mcap': 100, 'killed_3.mcap': 50}
    assert recording.bag_topics(bag)['/mode'] == ('std_msgs/msg/String', True)
    assert 'recovered 50 messages' in '\n'.join(report.lines())


def test_reindex_twice_changes_nothing(tmp_path):
    bag = killed_bag(tmp_path / 'killed', 355)
    reindex(bag)
    before = files_of(bag)
    again = reindex(bag)
    assert again.recovered == [] and again.message_count == 351
    assert files_of(bag) == before


def files_of(bag):
    return {str(p.relative_to(bag)): p.read_bytes() for p in bag.rglob('*') if p.is_file()}


def test_a_truncated_tail_is_cut_at_the_last_complete_chunk(tmp_path):
    bag = killed_bag(tmp_path / 'killed', 355)
    unfinished = check_bag(bag).unfinished_segment
    data = unfinished.read_bytes()
    # the last chunk (340 ... 349) loses its end: its message index after it is 175 bytes
    unfinished.write_bytes(data[:-300])
    report = reindex(bag)
    assert report.recovered[0].message_count == 40
    assert 0 < report.recovered[0].truncated_bytes < 1000
    assert setpoints(bag) == list(range(340))
    assert check_bag(bag).complete


def test_a_reindex_cut_short_is_finished_by_the_next(tmp_path):
    """The unfinished file was moved next to the segments when the reindex was killed."""
    bag = killed_bag(tmp_path / 'killed', 355)
    shutil.move(check_bag(bag).unfinished_segment, bag / 'killed_3.mcap')
    shutil.rmtree(bag / '.open_segment')
    check = check_bag(bag)
    assert not check.complete and check.unlisted_files == ['killed_3.mcap']
    report = reindex(bag)
    assert [(r.source, r.file_name, r.message_count) for r in report.recovered] == [
        ('killed_3.mcap', 'killed_3.mcap', 50)]
    assert setpoints(bag) == list(range(350))


def test_a_renamed_or_copied_bag_is_found_by_its_content(tmp_path):
    # Before, only <dirname>_<i>.mcap counted: a renamed bag was rewritten to "0 messages in 0
    # file(s)", and replay then played nothing with exit 0.
    bag = killed_bag(tmp_path / 'killed', 355)
    reindex(bag)
    renamed = tmp_path / 'renamed'
    bag.rename(renamed)
    copied = tmp_path / 'copied'
    shutil.copytree(renamed, copied)
    for folder in (renamed, copied):
        report = reindex(folder)
        assert report.message_count == 351 and report.files == [
            'killed_0.mcap', 'killed_1.mcap', 'killed_2.mcap', 'killed_3.mcap']
        assert setpoints(folder) == list(range(350)) and check_bag(folder).complete


def test_a_killed_bag_renamed_before_its_reindex_is_recovered_whole(tmp_path):
    bag = killed_bag(tmp_path / 'killed', 355)
    renamed = tmp_path / 'renamed'
    bag.rename(renamed)
    report = reindex(renamed)
    assert report.message_count == 351 and report.recovered[0].file_name == 'renamed_3.mcap'
    assert setpoints(renamed) == list(range(350))


def test_a_damaged_middle_segment_keeps_its_whole_messages_and_the_file_is_set_aside(tmp_path):
    # Before, the file was replaced by what could be read: the rest was deleted.
    bag = killed_bag(tmp_path / 'killed', 355)
    reindex(bag)
    middle = bag / 'killed_1.mcap'
    damaged = middle.read_bytes()[:len(middle.read_bytes()) // 2]
    middle.write_bytes(damaged)
    report = reindex(bag)
    item = next(r for r in report.recovered if r.source == 'killed_1.mcap')
    assert 0 < item.message_count < 100 and item.file_name == 'killed_1.mcap'
    assert (bag / item.set_aside).read_bytes() == damaged  # kept as it was
    assert item.set_aside == 'set_aside/killed_1.mcap'
    kept = setpoints(bag)
    assert kept == list(range(100)) + list(range(100, 100 + item.message_count)) + \
        list(range(200, 350))
    assert check_bag(bag).complete
    assert 'the file kept as it was in set_aside/killed_1.mcap' in '\n'.join(report.lines())


def test_a_file_the_metadata_lists_that_is_gone_is_not_dropped_from_it(tmp_path):
    bag = killed_bag(tmp_path / 'killed', 355)
    reindex(bag)
    metadata = (bag / 'metadata.yaml').read_text()
    (bag / 'killed_2.mcap').rename(tmp_path / 'elsewhere.mcap')
    with pytest.raises(BagError, match='metadata.yaml lists killed_2.mcap, which is no longer '
                                       'there .* nothing rewritten'):
        reindex(bag)
    assert (bag / 'metadata.yaml').read_text() == metadata


def test_a_file_that_is_no_mcap_is_neither_a_segment_nor_deleted(tmp_path):
    bag = killed_bag(tmp_path / 'killed', 355)
    (bag / 'killed_9.mcap').write_bytes(b'')  # created, never written: a crash at creation
    (bag / 'notes.txt').write_text('recorded on the roof')
    report = reindex(bag)
    assert 'killed_9.mcap' not in report.files and report.message_count == 351
    assert (bag / 'killed_9.mcap').exists() and (bag / 'notes.txt').exists()


def test_a_listed_segment_missing_or_miscounted_is_reported(tmp_path):
    bag = tmp_path / 'bag'
    with SegmentedBagWriter(bag, max_segment_bytes=200) as writer:
        writer.add_topic('/setpoint', FLOAT)
        for i in range(20):
            writer.write('/setpoint', i, TS.serialize_cdr(TS.types[FLOAT](float(i)),
                                                          FLOAT).tobytes())
    assert check_bag(bag).complete and check_bag(bag).message_count == 20
    text = (bag / 'metadata.yaml').read_text()
    (bag / 'metadata.yaml').write_text(text.replace('message_count: 20', 'message_count: 21'))
    (bag / 'bag_1.mcap').unlink()
    check = check_bag(bag)
    assert not check.complete
    assert any('bag_1.mcap cannot be read' in p for p in check.problems), check.problems


@pytest.mark.parametrize('make, reason', [
    (lambda tmp: tmp / 'nothing', 'does not exist'),
    (lambda tmp: (tmp / 'plain').mkdir() or tmp / 'plain', 'metadata.yaml is missing'),
])
def test_check_bag_of_no_bag(tmp_path, make, reason):
    check = check_bag(make(tmp_path))
    assert not check.complete and reason in check.summary()


def test_a_metadata_file_that_gives_a_key_twice_is_a_finding_not_a_silent_choice(tmp_path):
    bag = killed_bag(tmp_path / 'killed', 355)
    reindex(bag)
    assert check_bag(bag).complete
    metadata = bag / 'metadata.yaml'
    lines = metadata.read_text().splitlines(keepends=True)
    # A second message_count right after the first: one of them would silently win.
    at = next(i for i, line in enumerate(lines) if line.lstrip().startswith('message_count:'))
    indent = lines[at][:len(lines[at]) - len(lines[at].lstrip())]
    lines.insert(at + 1, f'{indent}message_count: 1\n')
    metadata.write_text(''.join(lines))
    check = check_bag(bag)
    assert not check.complete
    assert any("key 'message_count' given twice" in problem for problem in check.problems), \
        check.problems


def test_a_bag_being_written_is_not_reindexed(tmp_path):
    writer = SegmentedBagWriter(tmp_path / 'live')
    writer.add_topic('/setpoint', FLOAT)
    with pytest.raises(BagError, match='being written by a running process'):
        reindex(tmp_path / 'live')
    writer.close()
    assert reindex(tmp_path / 'live').message_count == 0


def test_bag_reindex_command(tmp_path):
    bag = killed_bag(tmp_path / 'killed', 355)
    done = subprocess.run([str(BIN / 'bag_reindex'), str(bag)], capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert 'recovered 50 messages from unfinished .open_segment/.open_segment.mcap into ' \
           'killed_3.mcap' in done.stdout
    assert f'{bag}: 351 messages in 4 file(s)' in done.stdout
    missing = subprocess.run([str(BIN / 'bag_reindex'), str(tmp_path / 'none')],
                             capture_output=True, text=True, timeout=60)
    assert missing.returncode == 2 and 'does not exist' in missing.stderr
    assert 'Traceback' not in missing.stderr


@pytest.fixture
def damaged_bag(tmp_path):
    """Make a complete bag whose middle segment file then loses its second half."""
    bag = killed_bag(tmp_path / 'killed', 355)
    reindex(bag)
    middle = bag / 'killed_1.mcap'
    middle.write_bytes(middle.read_bytes()[:middle.stat().st_size // 2])
    return bag


def test_a_bag_with_a_damaged_segment_is_refused_naming_the_file(damaged_bag):
    with pytest.raises(BagError, match=r'segment file killed_1.mcap \(.*\) cannot be read; '
                                       rf'`bag_reindex {damaged_bag}` keeps its whole messages, '
                                       r'or --skip-unreadable plays the rest'):
        recording.bag_topics(damaged_bag)
    with pytest.raises(BagError, match='killed_1.mcap'):
        list(recording.read_messages(damaged_bag))


def test_when_asked_the_readable_rest_of_a_damaged_bag_is_read_in_time_order(damaged_bag):
    topics = recording.bag_topics(damaged_bag, skip_unreadable=True)
    assert topics == {'/mode': ('std_msgs/msg/String', True),
                      '/setpoint': (FLOAT, False)}
    values = [TS.deserialize_cdr(raw, FLOAT).data for topic, _, _, raw in
              recording.read_messages(damaged_bag, ['/setpoint'], skip_unreadable=True)]
    assert values == list(range(100)) + list(range(200, 350))
    with pytest.raises(BagError, match='has no topic /nothing'):
        recording.read_messages(damaged_bag, ['/nothing'], skip_unreadable=True)


def test_replay_names_the_file_it_refuses(damaged_bag):
    done = subprocess.run([str(BIN / 'replay'), str(damaged_bag)], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 2 and 'Traceback' not in done.stderr, done.stderr
    assert done.stderr.startswith(f'replay: bag {damaged_bag}: segment file killed_1.mcap ('), \
        done.stderr
