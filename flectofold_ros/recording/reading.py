"""Reading a segmented bag back: its metadata, topics and messages, damaged segments named.

The bag's layout is :mod:`.writer`'s. Every function takes a bag directory (or a single
storage file) and refuses with :class:`~.writer.BagError` naming what it could not read;
``skip_unreadable`` reads around segments that cannot be read, each named.
"""

import functools
import heapq
from pathlib import Path
from typing import Iterable, Iterator, Optional

from rosbags.interfaces import Connection, ConnectionExtRosbag2, QosDurability
from rosbags.rosbag2 import Reader
import yaml

from flectofold_ros.recording.writer import BagError, Message, METADATA, PathLike


@functools.lru_cache(maxsize=1)
def _bag_loader() -> type:
    """Return PyYAML's safe loader class, refusing a mapping that gives one key twice.

    Made on first use: the rule lives in ``flectofold_model.safe_yaml``, and importing
    ``flectofold_model`` takes about a second that a recorder's start, which reads no YAML,
    should not spend.
    """
    from flectofold_model.safe_yaml import UniqueKeys
    return type('BagLoader', (UniqueKeys, yaml.SafeLoader), {'_source': METADATA})


def load_bag_yaml(text: str):
    """Parse YAML of a bag (its metadata.yaml, a channel's offered QoS profiles).

    With PyYAML's safe loader, the library :func:`write_metadata` writes with, refusing a key
    given twice (:class:`~flectofold_model.safe_yaml.DuplicateKeyError`: one value would
    silently win); the pure-Python composer, as libyaml's cannot be told to refuse them.
    """
    return yaml.load(text, Loader=_bag_loader())


def read_metadata(path: Path):
    """Return the parsed ``metadata.yaml`` of the bag directory at ``path``, as written.

    Raises what reading and parsing raise (``OSError``, ``yaml.YAMLError``, ...).
    """
    return load_bag_yaml((path / METADATA).read_text())


def _open_reader(path: PathLike) -> Reader:
    """Open a rosbag2 bag (directory or single storage file) or raise BagError.

    A bag directory one of whose segment files cannot be read is refused naming the file,
    with the two ways on: ``bag_reindex`` (keeps its whole messages) or playing the rest.
    """
    bag = Path(path)
    if not bag.exists():
        raise BagError(f'bag {bag} does not exist')
    try:
        reader = Reader(bag)
        reader.open()
    except Exception as err:  # rosbags raises ReaderError, FileNotFoundError, KeyError, ...
        unreadable = unreadable_segments(bag) if bag.is_dir() else []
        if unreadable:
            names = ', '.join(f'{name} ({why})' for name, why in unreadable)
            raise BagError(f'bag {bag}: segment file {names} cannot be read; `bag_reindex '
                           f'{bag}` keeps its whole messages, or --skip-unreadable plays the '
                           f'rest') from err
        raise BagError(f'{bag} is not a readable rosbag2 bag: {err}') from err
    return reader


def unreadable_segments(bag: Path) -> list[tuple[str, str]]:
    """Segment files a bag directory's metadata lists that cannot be read: (name, reason)."""
    try:
        files = _segment_files(bag)
    except Exception:  # no metadata or one that does not parse: no list to check
        return []
    found = []
    for file in files:
        try:
            with Reader(file):
                pass
        except Exception as err:  # rosbags raises ReaderError, FileNotFoundError, ...
            found.append((file.name, _one_line(err)))
    return found


def _one_line(error: Exception, limit: int = 120) -> str:
    text = ' '.join(str(error).split()) or type(error).__name__
    return text if len(text) <= limit else text[:limit - 3] + '...'


def _readable_rest(path: PathLike, skip_unreadable: bool) -> Optional[list[Path]]:
    """Return the readable segment files to play instead of the whole bag, or None.

    Only with ``skip_unreadable``, for a bag directory some of whose segment files cannot be
    read: the others, in the metadata's order. Each segment file is opened once.
    """
    bag = Path(path)
    if not (skip_unreadable and bag.is_dir()):
        return None
    skipped = {name for name, _ in unreadable_segments(bag)}
    return [file for file in _segment_files(bag) if file.name not in skipped] if skipped \
        else None


def _topics_of(files: list[Path]) -> dict[str, tuple[str, bool]]:
    """Topics of segment files: name -> (msgtype, latched), the first file's that has it."""
    topics: dict[str, tuple[str, bool]] = {}
    for file in files:
        with Reader(file) as reader:
            for conn in reader.connections:
                topics.setdefault(conn.topic, (conn.msgtype, is_latched(conn)))
    return topics


def is_latched(conn: Connection) -> bool:
    ext = conn.ext
    profiles = ext.offered_qos_profiles if isinstance(ext, ConnectionExtRosbag2) else []
    return any(p.durability == QosDurability.TRANSIENT_LOCAL for p in profiles)


def topic_list(topics: Iterable[str], shown: int = 6) -> str:
    """Shorten a list of topic names to: the first ``shown``, then how many more."""
    names = sorted(topics)
    if not names:
        return 'no topics'
    more = f' and {len(names) - shown} more' if len(names) > shown else ''
    return f'{len(names)} topics: {", ".join(names[:shown])}{more}'


def bag_topics(path: PathLike, skip_unreadable: bool = False) -> dict[str, tuple[str, bool]]:
    """Topics of a bag: name -> (msgtype, latched), latched from the offered QoS durability.

    ``skip_unreadable``: of the segment files that can be read only (a bag directory).
    """
    files = _readable_rest(path, skip_unreadable)
    if files is not None:
        return _topics_of(files)
    reader = _open_reader(path)
    try:
        return {conn.topic: (conn.msgtype, is_latched(conn)) for conn in reader.connections}
    finally:
        reader.close()


def _selected(reader: Reader, path: PathLike,
              topics: Optional[Iterable[str]]) -> list[Connection]:
    """Select the connections of the requested topics; BagError names unknown ones."""
    if topics is None:
        return list(reader.connections)
    if isinstance(topics, str):
        topics = [topics]
    wanted = set(topics)
    require_topics(path, {conn.topic for conn in reader.connections}, wanted)
    return [conn for conn in reader.connections if conn.topic in wanted]


def require_topics(path: PathLike, have: Iterable[str], wanted: Iterable[str]) -> None:
    """Raise BagError naming every topic of ``wanted`` that the bag at ``path`` lacks."""
    have = set(have)
    if missing := sorted(set(wanted) - have):
        raise BagError(f'bag {path} has no topic {", ".join(missing)}; '
                       f'it has {topic_list(have)}')


def _segment_files(path: Path) -> list[Path]:
    """Storage files of a bag directory, from its metadata.yaml."""
    info = read_metadata(path)
    return [path / Path(name).name
            for name in info['rosbag2_bagfile_information']['relative_file_paths']]


def _segment_messages(file: Path, topics: set[str]) -> Iterator[Message]:
    """Messages of one storage file, in time order."""
    with Reader(file) as reader:
        conns = [conn for conn in reader.connections if conn.topic in topics]
        if not conns:
            return
        for conn, t_ns, raw in reader.messages(connections=conns):
            yield conn.topic, conn.msgtype, t_ns, bytes(raw)


def read_messages(path: PathLike, topics: Optional[Iterable[str]] = None,
                  skip_unreadable: bool = False) -> Iterator[Message]:
    """Messages of a bag as ``(topic, msgtype, t_ns, raw)`` in time order over all segments.

    ``t_ns`` is the recorded time [ns], ``raw`` the CDR bytes. ``topics`` restricts the
    topics; a name the bag does not have raises BagError (before the first message), as does a
    path that is not a bag. rosbags reads a split bag segment after segment, so uncompressed
    MCAP segments are merged by timestamp here, in case late messages made them overlap.
    ``skip_unreadable``: a bag directory's segment files that cannot be read are left out (see
    :func:`unreadable_segments`), the others played.
    """
    files = _readable_rest(path, skip_unreadable)
    if files is not None:
        available = _topics_of(files)
        names = set(available) if topics is None else {topics} if isinstance(
            topics, str) else set(topics)
        require_topics(path, available, names)
        return heapq.merge(*(_segment_messages(file, names) for file in files),
                           key=lambda message: message[2])
    reader = _open_reader(path)
    try:
        conns = _selected(reader, path, topics)
        bag = Path(path)
        files = _segment_files(bag) if bag.is_dir() else [bag]
        mergeable = (not reader.compression_mode
                     and all(file.suffix == '.mcap' for file in files))
    except BaseException:
        reader.close()
        raise
    return _iterate(reader, conns, files if mergeable and len(files) > 1 else None)


def _iterate(reader: Reader, conns: list[Connection],
             files: Optional[list[Path]]) -> Iterator[Message]:
    try:
        if not conns:
            return
        if files is None:
            for conn, t_ns, raw in reader.messages(connections=conns):
                yield conn.topic, conn.msgtype, t_ns, bytes(raw)
            return
        names = {conn.topic for conn in conns}
        yield from heapq.merge(*(_segment_messages(file, names) for file in files),
                               key=lambda message: message[2])
    finally:
        reader.close()
