"""Bags on disk, without rclpy: crash-tolerant rosbag2 (MCAP) writing, and reading them back.

- :mod:`.writer`: the bag's layout and the rotated, crash-tolerant writer;
- :mod:`.reading`: metadata, topics and messages read back (damaged segments named);
- :mod:`.checking`: a bag directory complete, or what is missing and the fix;
- :mod:`.recovery`: ``bag_reindex``, recovering what a killed writer left.

The public names of the first three are importable from here.
"""

from flectofold_ros.recording.checking import (BagCheck, check_bag, is_mcap, segment_files,
                                               segment_index, unfinished_segment)
from flectofold_ros.recording.reading import (bag_topics, is_latched, load_bag_yaml,
                                              read_messages, read_metadata, require_topics,
                                              topic_list, unreadable_segments)
from flectofold_ros.recording.writer import (BAG_VERSION, BagError, fsync_dir, lock_bag,
                                             MCAP_MAGIC, MCAP_MESSAGE_OVERHEAD, Message,
                                             METADATA, offered_qos, out_of_room, PathLike,
                                             QOS_DEPTH, RecordedTopic, Segment,
                                             SegmentedBagWriter, WORKING_DIR, write_metadata)

__all__ = ['BAG_VERSION', 'BagCheck', 'BagError', 'bag_topics', 'check_bag', 'fsync_dir',
           'is_latched', 'is_mcap', 'load_bag_yaml', 'lock_bag', 'MCAP_MAGIC',
           'MCAP_MESSAGE_OVERHEAD', 'Message', 'METADATA', 'offered_qos', 'out_of_room',
           'PathLike', 'QOS_DEPTH', 'read_messages', 'read_metadata', 'RecordedTopic',
           'require_topics', 'Segment', 'segment_files', 'segment_index', 'SegmentedBagWriter',
           'topic_list', 'unfinished_segment', 'unreadable_segments', 'WORKING_DIR',
           'write_metadata']
