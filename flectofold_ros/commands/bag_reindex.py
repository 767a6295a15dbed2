"""Recover a bag whose recorder was killed: list every segment and rebuild metadata.yaml.

``bag_reindex BAG_DIR`` (in the spirit of ``ros2 bag reindex``): the messages of an unfinished
segment (left in ``BAG_DIR/.open_segment/`` by a SIGKILL or a power cut) are read with a
stream reader up to the truncated tail and written back as a closed segment, and
``metadata.yaml`` is rebuilt from the segment files present, so that rosbags, ``ros2 bag`` and
the ``mcap`` tools read the whole bag. Prints what it recovered; running it again changes
nothing. Exit code 2 for a path that is no bag or whose recorder still runs.
Details: ``msg_docs/bag_recorder.md``.
"""

import argparse
import sys

from flectofold_ros.recording import BagError
from flectofold_ros.runtime.runner import run_command


def parse_arguments(argv):
    parser = argparse.ArgumentParser(prog='bag_reindex', description=__doc__.split('\n')[0])
    parser.add_argument('bag', help='bag directory written by bag_recorder')
    return parser.parse_args(argv)


def reindex_and_report(bag):
    """Reindex the bag at ``bag`` and print the report; return the exit code (0)."""
    from flectofold_ros.recording.recovery import reindex
    print('\n'.join(reindex(bag).lines()), flush=True)
    return 0


def main(args=None):
    """``bag_reindex BAG_DIR``."""
    options = parse_arguments((sys.argv if args is None else args)[1:])
    return run_command('bag_reindex', lambda stop: reindex_and_report(options.bag),
                       bad_input=(BagError,), interrupted_code=130)


if __name__ == '__main__':
    sys.exit(main())
