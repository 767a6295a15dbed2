"""Checking a bag directory: complete, or what makes it incomplete and the fix.

:func:`check_bag` reads ``metadata.yaml`` and the summary of every segment (not their
messages); the helpers name the segment files a bag holds and the one left open.
"""

from pathlib import Path
from typing import NamedTuple, Optional

from rosbags.rosbag2 import Reader

from flectofold_ros.recording.reading import read_metadata
from flectofold_ros.recording.writer import MCAP_MAGIC, METADATA, PathLike, WORKING_DIR


class BagCheck(NamedTuple):
    """What :func:`check_bag` found in a bag directory.

    ``complete``: metadata.yaml lists every segment file present, each opens with rosbags'
    reader and holds the messages the metadata counts, and no unfinished segment is left.
    """

    path: Path
    complete: bool
    message_count: int
    """Messages listed in metadata.yaml, all directly readable when ``complete`` [messages]."""
    message_counts: dict[str, int]
    """Listed messages per topic [messages]."""
    files: list[str]
    """Segment files listed in metadata.yaml."""
    unfinished_segment: Optional[Path]
    """The file of a segment that was never closed (the recording runs, or it was killed)."""
    unfinished_bytes: int
    """Size of ``unfinished_segment``, 0 if there is none [bytes]."""
    unlisted_files: list[str]
    """Segment files present but not listed in metadata.yaml."""
    problems: list[str]
    """Everything that makes the bag incomplete, one sentence each."""

    def summary(self) -> str:
        """One line: complete with its figures, or INCOMPLETE with the reasons and the fix."""
        if self.complete:
            return (f'bag {self.path}: complete, {self.message_count} messages in '
                    f'{len(self.files)} file(s)')
        return (f'bag {self.path}: INCOMPLETE: {"; ".join(self.problems)}; '
                f'`bag_reindex {self.path}` recovers what is on disk')


def check_bag(path: PathLike) -> BagCheck:
    """Check whether the bag directory at ``path`` is complete; never raises for a bad bag.

    Reads metadata.yaml and the summary of each segment file (not their messages), so it is
    quick also for a long recording. Meant for after the recorder has stopped: while it runs,
    its open segment makes the bag incomplete.
    """
    bag = Path(path)
    problems: list[str] = []
    info = _load_metadata(bag, problems)
    listed = [Path(name).name for name in info.get('relative_file_paths') or []]
    counts = {entry['topic_metadata']['name']: int(entry['message_count'])
              for entry in info.get('topics_with_message_count') or []}
    file_counts = {Path(entry['path']).name: int(entry['message_count'])
                   for entry in info.get('files') or []}
    read_counts = dict.fromkeys(counts, 0)
    for name in listed:
        _check_segment(bag / name, file_counts.get(name), read_counts, problems)
    if read_counts != counts and not problems:
        problems.append(f'metadata.yaml counts {counts} messages per topic, the files '
                        f'hold {read_counts}')
    unlisted = sorted(set(segment_files(bag)) - set(listed)) if bag.is_dir() else []
    if unlisted:
        problems.append(f'segment file(s) not in metadata.yaml: {", ".join(unlisted)}')
    unfinished = unfinished_segment(bag)
    size = unfinished.stat().st_size if unfinished is not None else 0
    if unfinished is not None:
        problems.append(f'an unfinished segment of {size} bytes is left in {unfinished.parent}')
    return BagCheck(bag, not problems, int(info.get('message_count') or 0), counts, listed,
                    unfinished, size, unlisted, problems)


def _load_metadata(bag: Path, problems: list[str]) -> dict:
    """Return the ``rosbag2_bagfile_information`` of ``bag``; {} and a problem if unusable."""
    if not bag.is_dir():
        problems.append('not a bag directory' if bag.exists() else 'does not exist')
        return {}
    try:
        info = read_metadata(bag)['rosbag2_bagfile_information']
        if not isinstance(info, dict):
            raise TypeError('rosbag2_bagfile_information is not a mapping')
        return info
    except FileNotFoundError:
        problems.append(f'{METADATA} is missing')
    except Exception as err:  # PyYAML raises many types; a corrupt file is a finding here
        problems.append(f'{METADATA} cannot be read: {err}')
    return {}


def _check_segment(file: Path, listed_count: Optional[int], read_counts: dict[str, int],
                   problems: list[str]) -> None:
    """Open one listed segment, add its messages per topic to ``read_counts``."""
    try:
        with Reader(file) as reader:
            total = reader.message_count
            for conn in reader.connections:
                read_counts[conn.topic] = read_counts.get(conn.topic, 0) + conn.msgcount
    except Exception as err:  # rosbags raises ReaderError, FileNotFoundError, ...
        problems.append(f'{file.name} cannot be read: {err}')
        return
    if listed_count is not None and listed_count != total:
        problems.append(f'{file.name} holds {total} messages, metadata.yaml says {listed_count}')


def segment_index(name: str) -> Optional[int]:
    """Index ``i`` of a segment file name ``<prefix>_<i>.mcap``; None for other names.

    The prefix is the bag directory's name when the recorder wrote the file, whatever the
    directory is called now (a bag renamed or copied keeps its files' names).
    """
    stem, dot, suffix = name.rpartition('.')
    prefix, _, index = stem.rpartition('_')
    if dot and suffix == 'mcap' and prefix and index.isdigit():
        return int(index)
    return None


def is_mcap(file: Path) -> bool:
    """Whether ``file`` starts with the MCAP magic: a segment, by its content, not its name."""
    try:
        with file.open('rb') as stream:
            return stream.read(len(MCAP_MAGIC)) == MCAP_MAGIC
    except OSError:
        return False


def segment_files(bag: Path) -> list[str]:
    """Names of the segment files in ``bag``: its MCAP files, found by their content.

    In the order of their index (``<prefix>_<i>.mcap``), then of their names; files in the
    hidden working directories are not segments.
    """
    found = [(segment_index(p.name), p.name) for p in bag.iterdir()
             if p.is_file() and not p.name.startswith('.') and is_mcap(p)]
    return [name for _, name in sorted(found, key=lambda item: (
        item[0] is None, -1 if item[0] is None else item[0], item[1]))]


def unfinished_segment(bag: Path) -> Optional[Path]:
    """Return the open segment's file left in the working directory, if any."""
    work = bag / WORKING_DIR
    files = sorted(work.glob('*.mcap')) if work.is_dir() else []
    return files[0] if files else None
