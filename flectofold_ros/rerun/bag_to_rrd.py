"""Turn a recorded bag into a Rerun ``.rrd`` without a running graph (and without rclpy).

The bag's ``/facade/panel_states`` and ``/facade/sun`` go, in record-time order, through the
same :func:`flectofold_ros.rerun.scene.feed` as the live ``rerun_bridge`` gets them, so the
file shows what the live bridge showed (both topics are stamped; the record time only paces
the flushes).
"""

from pathlib import Path
import struct
import time

from rosbags.serde import SerdeError
from rosbags.typesys import get_typestore, Stores

from flectofold_ros.recording import (bag_topics, BagError, read_messages,
                                      require_topics, topic_list)
from flectofold_ros.rerun.scene import FacadeScene, feed, scene_topics
from flectofold_ros.rerun.sinks import check_rrd_path, open_recording
from flectofold_ros.wire import contract

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)


def decode(raw, msgtype, typestore=TYPESTORE):
    """Deserialize CDR bytes; accept the zero padding rclpy leaves after empty sequences.

    Fast CDR (rclpy) aligns the end of a ``JointState`` with empty ``velocity`` and
    ``effort`` to 8 bytes; rosbags' ``deserialize_cdr`` rejects the extra bytes as a size
    mismatch. The message itself is complete, so only trailing zeros are allowed here.
    """
    try:
        return typestore.deserialize_cdr(raw, msgtype)
    except SerdeError:
        if len(raw) < 4 or bytes(raw[:2]) != b'\x00\x01':
            raise
    msgdef = typestore.get_msgdef(msgtype)
    try:
        message, end = msgdef.deserialize_cdr_le(raw[4:], 0, msgdef.cls, typestore)
    except (struct.error, UnicodeDecodeError, ValueError) as error:
        raise SerdeError(f'could not deserialize {msgtype}: {error}') from None
    if any(raw[4 + end:]):
        raise SerdeError(f'{msgtype}: {len(raw) - 4 - end} unexpected bytes after the message')
    return message


def convert(bag_path, rrd_path, facade, color_by='closure', flush_period_s=1.0,
            min_change_rad=1e-3, strict=False, topics=None, progress=None,
            progress_period_s=5.0, skip_unreadable=False):
    """Write ``rrd_path`` from the bag at ``bag_path``; return the scene's counts.

    Every published state is kept (the live bridge merges states that arrive between two of
    its flushes); ``flush_period_s`` of bag (ROS) time batches the time series.
    ``topics`` restricts the conversion to some of the bag's topics. The bag must hold
    ``/facade/panel_states`` (``BagError`` otherwise): bags with only the per-panel topics,
    as recorded before it existed, are not supported.
    ``progress`` is called with a line of text every ``progress_period_s`` of wall time.
    """
    rrd_path = check_rrd_path(rrd_path)
    available = bag_topics(bag_path, skip_unreadable)
    if topics is not None:
        require_topics(bag_path, available, topics)
        available = {topic: available[topic] for topic in topics}
    if contract.PANEL_STATES.name not in available:
        raise BagError(f'{bag_path}: no {contract.PANEL_STATES.name} in the '
                       f'{"chosen topics" if topics is not None else "bag"} (it has '
                       f'{topic_list(available)}); the scene is built from it, and bags '
                       f'recorded with only the per-panel topics cannot be converted')
    wanted = [topic.name for topic in scene_topics(facade) if topic.name in available]
    recording = open_recording(f'{facade.name}-{Path(bag_path).name}', None, rrd_path, strict)
    scene = FacadeScene(facade, recording, color_by, min_change_rad, every_state=True)
    scene.log_static()
    flush_ns, next_flush_ns, decode_errors = round(flush_period_s * 1e9), None, 0
    say, said = progress or (lambda text: None), time.monotonic()
    for count, (topic, msgtype, t_ns, raw) in enumerate(
            read_messages(bag_path, wanted, skip_unreadable)):
        if count % 256 == 0 and time.monotonic() - said > progress_period_s:
            said = time.monotonic()
            say(f'{count} messages converted, up to '
                f'{time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime(t_ns / 1e9))}')
        if next_flush_ns is None:
            next_flush_ns = t_ns + flush_ns
        elif t_ns >= next_flush_ns:
            scene.flush()
            next_flush_ns = t_ns + flush_ns
        try:
            message = decode(raw, msgtype)
        except SerdeError:
            decode_errors += 1
            continue
        feed(scene, topic, message, t_ns)
        if scene.counts.misplaced:  # another facade's bag: say so now, not after all of it
            break
    scene.flush()
    scene.counts.rejected += decode_errors
    recording.flush()
    recording.disconnect()
    if scene.counts.misplaced:
        Path(rrd_path).unlink(missing_ok=True)
        raise BagError(
            f'{bag_path}: {scene.counts.misplaced} panel states are not where facade '
            f'{facade.name!r} puts their panels: the bag was recorded with another facade; '
            f'convert it with --facade <the facade it was recorded with>')
    return scene.counts
