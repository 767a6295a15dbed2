"""Play a recorded bag back onto the graph, or turn it into a Rerun ``.rrd``.

``ros2 run flectofold_ros replay BAG [--rate 2] [--loop] [--topics /clock /facade/sun ...]``
publishes the bag's messages, serialized bytes as recorded, at their recorded spacing divided
by ``--rate``; the bag's ``/clock`` goes out with them, so nodes on ``use_sim_time`` (a
``rerun_bridge``, say) follow the recorded day. ``replay BAG --to-rrd day.rrd`` converts the
bag offline instead: no graph, no rclpy. Contract: ``msg_docs/replay.md``.
"""

import argparse
import math
from pathlib import Path
import sys
import time

from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_ros.recording import BagError, unreadable_segments
from flectofold_ros.rerun.bag_to_rrd import convert
from flectofold_ros.runtime.runner import Interrupted, run_command

DEFAULT_FLUSH_PERIOD_S = 1.0


def parse_arguments(argv):
    parser = argparse.ArgumentParser(prog='replay', description=__doc__.split('\n')[0])
    parser.add_argument('bag', help='bag directory (rosbag2, as bag_recorder writes it)')
    parser.add_argument('--rate', type=float, default=1.0,
                        help='playback speed factor (default 1: as recorded)')
    parser.add_argument('--loop', action='store_true', help='play again from the start, '
                        'until Ctrl-C')
    parser.add_argument('--topics', nargs='+', metavar='TOPIC',
                        help='play only these topics (default: all)')
    parser.add_argument('--to-rrd', metavar='OUT.rrd',
                        help='convert the bag to a Rerun recording instead of playing it')
    parser.add_argument('--facade', default='', help='facade YAML for --to-rrd (default: '
                        'the embedded demonstrator)')
    parser.add_argument('--color-by', default='closure', choices=('closure', 'pressure'),
                        help='panel colour for --to-rrd')
    parser.add_argument('--skip-unreadable', action='store_true',
                        help='leave out segment files that cannot be read (named) and play or '
                        'convert the rest; without it such a bag is refused')
    parser.add_argument('--flush-period', type=float, default=DEFAULT_FLUSH_PERIOD_S,
                        help='--to-rrd: bag seconds between logging what changed (default 1)')
    options = parser.parse_args(argv)
    if not (math.isfinite(options.rate) and 0.001 <= options.rate <= 10000.0):
        parser.error(f'--rate must lie in [0.001, 10000], got {options.rate:g}')
    if not (math.isfinite(options.flush_period) and options.flush_period > 0.0):
        parser.error(f'--flush-period must be a positive number, got {options.flush_period:g}')
    return options


def to_rrd(options):
    """Convert the bag offline (no graph, no rclpy); print what was written."""
    facade = load_facade(options.facade or DEFAULT_FACADE)
    started = time.monotonic()
    say_skipped(options)
    counts = convert(options.bag, options.to_rrd, facade, options.color_by,
                     options.flush_period, topics=options.topics,
                     progress=lambda text: print(f'replay: {text}', flush=True),
                     skip_unreadable=options.skip_unreadable)
    print(f'replay: {options.to_rrd}: {counts.meshes_logged} meshes, {counts.samples_logged} '
          f'samples, {counts.events_logged} events, {counts.rejected} rejected, in '
          f'{time.monotonic() - started:.1f} s', flush=True)
    return 0


def say_skipped(options):
    """Print one line per segment file ``--skip-unreadable`` leaves out."""
    if not options.skip_unreadable or not Path(options.bag).is_dir():
        return
    for name, why in unreadable_segments(Path(options.bag)):
        print(f'replay: skipping {name}: it cannot be read ({why}); `bag_reindex '
              f'{options.bag}` keeps its whole messages', flush=True)


def without_ros_args(argv):
    """``argv`` without ``--ros-args ... [--]`` blocks (rclpy is not needed for --to-rrd)."""
    kept, inside = [], False
    for argument in argv:
        if argument == '--ros-args':
            inside = True
        elif inside and argument == '--':
            inside = False
        elif not inside:
            kept.append(argument)
    return kept


def main(args=None):
    """``ros2 run flectofold_ros replay BAG [--rate R] [--loop] [--topics ...] [--to-rrd OUT]``.

    Also ``--skip-unreadable``, ``--facade``, ``--color-by``, ``--flush-period``.
    """
    try:
        options = parse_arguments(without_ros_args(sys.argv if args is None else args)[1:])
        if options.to_rrd:
            return run_command('replay', lambda stop: to_rrd(options), bad_input=(BagError,),
                               interrupted_code=130)
        # rclpy only when playing onto the graph; importing it takes a second or more, and a
        # stop signal then ends the start (the executables' handlers are installed).
        from flectofold_ros.nodes.replay import play
    except Interrupted:
        return 0
    say_skipped(options)
    return play(options, args)


if __name__ == '__main__':
    sys.exit(main())
