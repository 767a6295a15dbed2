"""Where the Rerun recording goes: an .rrd file, a viewer at an address, or one spawned here.

No rclpy: the offline converter uses it too. Servers and spawned viewers bind 127.0.0.1 only.
"""

from datetime import datetime
import os
from pathlib import Path
import subprocess
import time

import rerun as rr

from flectofold_ros.rerun.scene import facade_blueprint

APPLICATION_ID = 'flectofold'
LOOPBACK = '127.0.0.1'


class BridgeError(ValueError):
    """A sink that cannot be opened: bad path, unwritable directory, bad viewer address."""


def check_rrd_path(path):
    """Return ``path`` as a Path after checking an .rrd can be written there."""
    path = Path(path)
    if path.suffix != '.rrd':
        raise BridgeError(f'rrd_path {str(path)!r} must end in .rrd')
    if path.is_dir():
        raise BridgeError(f'rrd_path {str(path)!r} is a directory')
    if not path.parent.is_dir():
        raise BridgeError(f'rrd_path {str(path)!r}: directory {str(path.parent)!r} does not exist')
    try:
        with open(path, 'ab'):
            pass
    except OSError as error:
        raise BridgeError(f'rrd_path {str(path)!r} cannot be written: {error.strerror}') from None
    return path


def check_viewer_url(url):
    """Check a Rerun gRPC proxy URL: ``rerun+http(s)://host:port/proxy``."""
    if not url.startswith(('rerun+http://', 'rerun+https://')) or not url.endswith('/proxy'):
        raise BridgeError(f'viewer {url!r} is not auto, spawn, none or a Rerun gRPC URL like '
                          f'rerun+http://{LOOPBACK}:9876/proxy')
    return url


def rerun_binary():
    """Return the real viewer binary of the rerun-sdk wheel (not the Python wrapper)."""
    import rerun_cli
    return str(Path(rerun_cli.__file__).with_name('rerun'))


def spawn_viewer(port):
    """Start a native viewer bound to 127.0.0.1 and return its gRPC URL.

    ``rr.spawn`` would bind every interface, so the viewer is started here with ``--bind``.
    It is detached: closing the bridge leaves the user's window open.
    """
    subprocess.Popen([rerun_binary(), '--bind', LOOPBACK, '--port', str(port)],
                     start_new_session=True, stdout=subprocess.DEVNULL)
    time.sleep(1.0)  # the viewer's server must listen before the first connection attempt
    return f'rerun+http://{LOOPBACK}:{port}/proxy'


def choose_sinks(viewer, rrd_path, port, environ=os.environ):
    """Return ``(viewer URL or None, .rrd path or None, spawn?)`` from the parameters."""
    has_display = bool(environ.get('DISPLAY') or environ.get('WAYLAND_DISPLAY'))
    spawn = viewer == 'spawn' or (viewer == 'auto' and has_display)
    url = None
    if viewer not in ('auto', 'spawn', 'none'):
        url = check_viewer_url(viewer)
    if not rrd_path and url is None and not spawn:
        rrd_path = f'flectofold_{datetime.now().strftime("%Y%m%d_%H%M%S")}.rrd'
    return url, (check_rrd_path(rrd_path) if rrd_path else None), spawn


def open_recording(recording_id, url, rrd_path, strict=False):
    """Open an ``rr.RecordingStream`` with the chosen sinks and the default blueprint."""
    if strict:
        rr.set_strict_mode(True)
    recording = rr.RecordingStream(APPLICATION_ID, recording_id=recording_id)
    sinks = []
    if rrd_path is not None:
        sinks.append(rr.FileSink(str(rrd_path)))
    if url is not None:
        sinks.append(rr.GrpcSink(url))
    recording.set_sinks(*sinks, default_blueprint=facade_blueprint())
    return recording
