"""Recover a bag after a hard kill (``bag_reindex``, in the spirit of ``ros2 bag reindex``).

A recorder killed with SIGKILL (or a power cut) leaves its open segment unfinished: an MCAP
file without summary and footer in ``<bag>/.open_segment/``, whose complete chunks are all
there but which rosbags' reader cannot open, and a ``metadata.yaml`` that lists only the closed
segments (see :mod:`flectofold_ros.recording`). :func:`reindex`:

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

from flectofold_ros.recording import (
    BagError, fsync_dir, is_latched, load_bag_yaml, lock_bag, METADATA, PathLike, read_metadata,
    RecordedTopic, Segment, segment_files, segment_index, SegmentedBagWriter, unfinished_segment,
    write_metadata)

#: Hidden directory where a recovered segment is written before it joins the bag.
RECOVERY_DIR = '.reindex'
#: Directory of the bag where a file that could not be read whole is kept, as it was.
SET_ASIDE_DIR = 'set_aside'


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
    set_aside: str = ''
    """Where the file is kept as it was, relative to the bag (it is never deleted)."""


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
                         f'truncated tail not readable, the file kept as it was in '
                         f'{item.set_aside}')
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
        listed = _listed_files(bag)
        recovered = [_recover(bag, source) for source in _unfinished(bag)]
        segments, topics, digests = _scan(bag)
        _refuse_to_hide(bag, listed, recovered)
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


def _listed_files(bag: Path) -> list[str]:
    """Segment files the bag's metadata.yaml lists now (none if it has none or is unreadable)."""
    try:
        info = read_metadata(bag)
        return [Path(name).name for name in
                info['rosbag2_bagfile_information']['relative_file_paths']]
    except Exception:  # no metadata, or one that does not parse: nothing listed to keep
        return []


def _refuse_to_hide(bag: Path, listed: list[str], recovered: list[Recovered]) -> None:
    """Refuse a metadata.yaml that would drop a file the present one lists and that is gone.

    A rebuilt metadata lists the segment files present; one listed before that is neither
    present nor recovered was moved or renamed away, and dropping it from the list would hide
    its messages. Nothing is rewritten then.
    """
    present = set(segment_files(bag)) | {item.source for item in recovered}
    if missing := [name for name in listed if name not in present]:
        raise BagError(f'{bag}: {METADATA} lists {", ".join(missing)}, which is no longer '
                       f'there (moved or renamed?); rebuilding it would hide those messages: '
                       f'nothing rewritten. Put the file(s) back, or move {METADATA} aside to '
                       f'index what is there')


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
    """Stream-read ``source`` into a closed segment of ``bag`` in its place; keep the original.

    The original file is never deleted: it is linked into :data:`SET_ASIDE_DIR` before the
    recovered segment replaces it, so a reindex cut short at any point loses nothing (run
    again, it recovers the file again, into another set-aside name).
    """
    origin = str(source.relative_to(bag))
    if source.parent != bag:
        # The working directory's file becomes the next segment file first, so that a
        # reindex cut short recovers it from there, once.
        target = _next_segment(bag)
        os.replace(source, target)
        fsync_dir(bag)
        shutil.rmtree(source.parent)
        source = target
    work = bag / RECOVERY_DIR
    shutil.rmtree(work, ignore_errors=True)
    with SegmentedBagWriter(work) as writer:
        count, truncated, skipped = _copy_messages(source, writer)
    aside = _set_aside(bag, source)
    written = work / f'{RECOVERY_DIR}_0.mcap'
    if written.exists():
        with written.open('rb') as stream:
            os.fsync(stream.fileno())
        os.replace(written, source)
    else:
        source.unlink()  # its one other name, in the set-aside directory, keeps it
    fsync_dir(bag)
    shutil.rmtree(work)
    return Recovered(origin, source.name if count else None, count, truncated, skipped,
                     str(aside.relative_to(bag)))


def _next_segment(bag: Path) -> Path:
    """Return a free segment file name after the last index of the bag's segment files."""
    indices = [segment_index(name) for name in segment_files(bag)]
    last = max((i for i in indices if i is not None), default=-1)
    target = bag / f'{bag.name}_{last + 1}.mcap'
    while target.exists():
        last += 1
        target = bag / f'{bag.name}_{last + 1}.mcap'
    return target


def _set_aside(bag: Path, file: Path) -> Path:
    """Give ``file`` a second name in the set-aside directory (a hard link); return it."""
    folder = bag / SET_ASIDE_DIR
    folder.mkdir(exist_ok=True)
    kept, number = folder / file.name, 1
    while kept.exists():
        number += 1
        kept = folder / f'{file.stem}.{number}{file.suffix}'
    os.link(file, kept)
    fsync_dir(folder)
    return kept


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
        profiles = load_bag_yaml(channel.metadata.get('offered_qos_profiles', '')) or []
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
                topics.setdefault(conn.topic, RecordedTopic(conn.msgtype, is_latched(conn)))
            if reader.message_count:
                segments.append(Segment(name, reader.start_time, reader.end_time - 1, counts))
    digests = {name: typestore.hash_rihs01(topic.msgtype)
               for name, topic in topics.items() if topic.msgtype in typestore.fielddefs}
    return segments, topics, digests
