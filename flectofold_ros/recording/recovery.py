"""Recover a bag after a hard kill (``bag_reindex``, in the spirit of ``ros2 bag reindex``).

A recorder killed with SIGKILL (or a power cut) leaves its open segment unfinished: an MCAP
file without summary and footer in ``<bag>/.open_segment/``, whose complete chunks are all
there but which rosbags' reader cannot open, and a ``metadata.yaml`` that lists only the closed
segments (see :mod:`flectofold_ros.recording.bag_segments`). :func:`reindex`:

1. moves the unfinished file next to the closed ones, as the next segment file
   ``<name>_<i>.mcap`` (a segment file that rosbags cannot open stays where it is);
2. reads it with the ``mcap`` library's stream reader, record after record, up to the first
   incomplete one (the truncated tail: the chunk being written when the process died), writes
   every message read into a closed segment in a hidden directory and renames that over it;
3. rebuilds ``metadata.yaml`` from the segment files present, read with rosbags.

Each step leaves a bag that the next run of :func:`reindex` finishes: a file is renamed only
when complete (fsync first), and the metadata is rebuilt from the files present, so running
it again changes nothing and recovers nothing twice. A bag whose recorder still runs (it
holds the bag's lock) is refused.
"""

import os
from pathlib import Path
import shutil
import struct
from typing import NamedTuple, Optional

from mcap.exceptions import McapError
from mcap.records import Channel, Message, Schema
from mcap.stream_reader import StreamReader
from rosbags.rosbag2 import Reader
from rosbags.typesys import get_typestore, Stores
from ruamel.yaml import YAML

from flectofold_ros.recording.bag_segments import (
    _fsync_dir, _is_latched, BagError, lock_bag, METADATA, PathLike, RecordedTopic, Segment,
    segment_files, segment_index, SegmentedBagWriter, unfinished_segment, write_metadata)

#: Hidden directory where a recovered segment is written before it joins the bag.
RECOVERY_DIR = '.reindex'


class Recovered(NamedTuple):
    """Messages recovered from one unfinished segment file."""

    source: str
    """The unfinished file, relative to the bag."""
    file_name: Optional[str]
    """The closed segment written with them; None when the file held no complete message."""
    message_count: int
    """Messages recovered [messages]."""
    truncated_bytes: int
    """Bytes at the end of the file that are no complete MCAP record (the lost tail) [bytes]."""
    skipped: dict[str, int]
    """Messages not recovered per topic, with a type unknown to the ROS 2 Jazzy typestore."""


class ReindexReport(NamedTuple):
    """What :func:`reindex` did to a bag."""

    path: Path
    files: list[str]
    """Segment files listed in the rebuilt metadata.yaml."""
    message_count: int
    """Messages the rebuilt metadata.yaml lists, all directly readable now [messages]."""
    message_counts: dict[str, int]
    recovered: list[Recovered]

    def lines(self) -> list[str]:
        """Return the report as ``bag_reindex`` prints it."""
        lines = [f'bag_reindex: {self.path}: {self.message_count} messages in '
                 f'{len(self.files)} file(s) listed in {METADATA}']
        for item in self.recovered:
            target = f'into {item.file_name}' if item.file_name else '(nothing to keep)'
            lines.append(f'  recovered {item.message_count} messages from unfinished '
                         f'{item.source} {target}; {item.truncated_bytes} bytes of '
                         f'truncated tail lost')
            lines += [f'  not recovered: {count} messages of {topic} (type unknown)'
                      for topic, count in item.skipped.items()]
        if not self.recovered:
            lines.append('  no unfinished segment')
        return lines


def reindex(path: PathLike) -> ReindexReport:
    """Recover the unfinished segments of the bag at ``path`` and rebuild its metadata.yaml.

    Raises
    ------
    BagError
        ``path`` is no bag directory, its recorder still runs, or a file cannot be written.
    """
    bag = Path(path)
    if not bag.is_dir():
        reason = 'is not a directory' if bag.exists() else 'does not exist'
        raise BagError(f'bag {bag} {reason}')
    if not ((bag / METADATA).exists() or segment_files(bag) or unfinished_segment(bag)):
        raise BagError(f'{bag} is not a bag: no {METADATA}, segment or unfinished segment')
    lock = lock_bag(bag)
    try:
        recovered = [_recover(bag, source) for source in _unfinished(bag)]
        segments, topics, digests = _scan(bag)
        write_metadata(bag, segments, topics, digests)
        (bag / f'{METADATA}.tmp').unlink(missing_ok=True)
    except OSError as err:
        raise BagError(f'cannot reindex bag {bag}: {err}') from err
    finally:
        if lock is not None:
            os.close(lock)
    counts = dict.fromkeys(topics, 0)
    for segment in segments:
        for name, count in segment.counts.items():
            counts[name] += count
    return ReindexReport(bag, [s.file_name for s in segments], sum(counts.values()), counts,
                         recovered)


def _unfinished(bag: Path) -> list[Path]:
    """Segment files that rosbags cannot open, then the working directory's file."""
    broken = [bag / name for name in segment_files(bag) if not _readable(bag / name)]
    unfinished = unfinished_segment(bag)
    return broken + ([unfinished] if unfinished is not None else [])


def _readable(file: Path) -> bool:
    try:
        with Reader(file):
            return True
    except Exception:  # rosbags raises ReaderError, struct.error, ... for a broken file
        return False


def _recover(bag: Path, source: Path) -> Recovered:
    """Stream-read ``source`` into a closed segment of ``bag`` in its place."""
    origin = str(source.relative_to(bag))
    if source.parent != bag:
        # The working directory's file becomes the next segment file first, so that a
        # reindex cut short recovers it from there, once.
        last = max((segment_index(bag, name) for name in segment_files(bag)), default=-1)
        target = bag / f'{bag.name}_{last + 1}.mcap'
        os.replace(source, target)
        _fsync_dir(bag)
        shutil.rmtree(source.parent)
        source = target
    work = bag / RECOVERY_DIR
    shutil.rmtree(work, ignore_errors=True)
    with SegmentedBagWriter(work) as writer:
        count, truncated, skipped = _copy_messages(source, writer)
    written = work / f'{RECOVERY_DIR}_0.mcap'
    if written.exists():
        with written.open('rb') as stream:
            os.fsync(stream.fileno())
        os.replace(written, source)
    else:
        source.unlink()
    _fsync_dir(bag)
    shutil.rmtree(work)
    return Recovered(origin, source.name if count else None, count, truncated, skipped)


def _copy_messages(source: Path, writer: SegmentedBagWriter) -> tuple[int, int, dict[str, int]]:
    """Write every complete message of ``source`` to ``writer``.

    Returns the messages copied, the bytes of the truncated tail and the messages skipped per
    topic of an unknown type.
    """
    schemas: dict[int, Schema] = {}
    topics: dict[int, str] = {}
    skipped: dict[str, int] = {}
    count, good_bytes = 0, 0
    with source.open('rb') as stream:
        try:
            for record in StreamReader(stream).records:
                if isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    topics[record.id] = _add_channel(record, schemas, writer, skipped)
                elif isinstance(record, Message):
                    topic = topics.get(record.channel_id, '(unknown channel)')
                    if topic in skipped or record.channel_id not in topics:
                        skipped[topic] = skipped.get(topic, 0) + 1
                    else:
                        writer.write(topic, record.log_time, record.data)
                        count += 1
                good_bytes = stream.tell()
        except (McapError, struct.error, ValueError, UnicodeDecodeError):
            pass  # the truncated tail: an incomplete record, or bytes that make no record
    return count, source.stat().st_size - good_bytes, skipped


def _add_channel(channel: Channel, schemas: dict[int, Schema], writer: SegmentedBagWriter,
                 skipped: dict[str, int]) -> str:
    """Register the channel's topic with ``writer``; return the topic name."""
    schema = schemas.get(channel.schema_id)
    msgtype = schema.name if schema is not None else ''
    try:
        writer.add_topic(channel.topic, msgtype, latched=_offered_latched(channel))
    except BagError:
        skipped.setdefault(channel.topic, 0)
    return channel.topic


def _offered_latched(channel: Channel) -> bool:
    """Whether the channel's recorded offered QoS is transient local."""
    try:
        profiles = YAML(typ='safe').load(channel.metadata.get('offered_qos_profiles', '')) or []
        return any(str(profile.get('durability')) in ('transient_local', '1')
                   for profile in profiles)
    except Exception:  # a profile that does not parse is recorded volatile
        return False


def _scan(bag: Path) -> tuple[list[Segment], dict[str, RecordedTopic], dict[str, str]]:
    """Segments (in index order), topics and type hashes of the segment files present."""
    typestore = get_typestore(Stores.ROS2_JAZZY)
    segments: list[Segment] = []
    topics: dict[str, RecordedTopic] = {}
    for name in segment_files(bag):
        with Reader(bag / name) as reader:
            counts: dict[str, int] = {}
            for conn in reader.connections:
                counts[conn.topic] = counts.get(conn.topic, 0) + conn.msgcount
                topics.setdefault(conn.topic, RecordedTopic(conn.msgtype, _is_latched(conn)))
            if reader.message_count:
                segments.append(Segment(name, reader.start_time, reader.end_time - 1, counts))
    digests = {name: typestore.hash_rihs01(topic.msgtype)
               for name, topic in topics.items() if topic.msgtype in typestore.fielddefs}
    return segments, topics, digests
