"""Where the Rerun recording goes: an .rrd file, a viewer at an address, or one spawned here.

No rclpy: the offline converter uses it too. Servers and spawned viewers bind 127.0.0.1 only.

A spawned viewer connects to a gRPC server the recording hosts (127.0.0.1, ``viewer_port``),
so the viewer's fate never reaches the logging side: a viewer that cannot open a window (no
display), is missing, is closed or killed leaves the server (bounded memory) and the .rrd,
which a spawning bridge always writes, as they were. Without a display no viewer is spawned.
"""

from datetime import datetime
import os
from pathlib import Path
import socket
import subprocess
from urllib.parse import urlsplit

import rerun as rr

from flectofold_ros.rerun.scene import facade_blueprint

APPLICATION_ID = 'flectofold'
LOOPBACK = '127.0.0.1'
#: Memory the hosted server keeps for viewers that connect late; the oldest goes first.
SERVER_MEMORY_LIMIT = '256MiB'
#: Seconds a spawned viewer gets to fail at once (no display, bad binary) before it counts.
VIEWER_START_S = 1.0
#: Seconds to wait for a viewer's port, and for the last data to reach the sinks on close.
CONNECT_TIMEOUT_S, FLUSH_TIMEOUT_S = 1.0, 2.0


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


def server_url(port):
    """Return the gRPC URL of the server a spawning recording hosts on 127.0.0.1."""
    return f'rerun+http://{LOOPBACK}:{port}/proxy'


def spawn_viewer(url, warn, binary=None):
    """Start a native viewer that connects to ``url``; return it, or None (warned why).

    ``rr.spawn`` would bind every interface, so the viewer is started here with ``--bind``
    (it still hosts a server of its own, on a free port). It is detached: closing the bridge
    leaves the user's window open. A viewer that ends within :data:`VIEWER_START_S` failed.
    """
    try:
        viewer = subprocess.Popen([binary or rerun_binary(), '--bind', LOOPBACK, '--connect',
                                   url], start_new_session=True, stdout=subprocess.DEVNULL)
    except (OSError, ImportError) as error:
        warn(f'cannot start the Rerun viewer ({error}); saving the .rrd only')
        return None
    try:
        code = viewer.wait(timeout=VIEWER_START_S)
    except subprocess.TimeoutExpired:
        return viewer
    warn(f'the Rerun viewer exited at once (exit {code}); saving the .rrd only')
    return None


def port_free(port):
    """Whether nothing listens on 127.0.0.1:``port`` (a server can take it)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        try:
            probe.bind((LOOPBACK, port))
        except OSError:
            return False
    return True


def reachable(url, timeout_s=CONNECT_TIMEOUT_S):
    """Whether something accepts TCP connections at the host and port of a gRPC ``url``."""
    parts = urlsplit(url)
    try:
        port = parts.port or (443 if parts.scheme.endswith('https') else 80)
        with socket.create_connection((parts.hostname, port), timeout=timeout_s):
            return True
    except (OSError, ValueError):
        return False


def default_rrd_path():
    """Return ``flectofold_<time>.rrd`` (in the working directory)."""
    return f'flectofold_{datetime.now().strftime("%Y%m%d_%H%M%S")}.rrd'


def has_display(environ=os.environ):
    """Whether a native window can open: ``DISPLAY`` or ``WAYLAND_DISPLAY`` is set."""
    return bool(environ.get('DISPLAY') or environ.get('WAYLAND_DISPLAY'))


def choose_sinks(viewer, rrd_path, port, environ=os.environ, warn=None):
    """Return ``(viewer URL or None, .rrd path or None, spawn?)`` from the parameters.

    A spawned viewer always comes with the .rrd (the viewer may go at any moment); without
    a display, or with ``port`` taken, ``spawn`` falls back to the .rrd alone (``warn`` says
    so). A viewer URL nobody answers at falls back to the .rrd too.
    """
    warn = warn or (lambda message: None)
    spawn = viewer == 'spawn' or (viewer == 'auto' and has_display(environ))
    url = None
    if viewer not in ('auto', 'spawn', 'none'):
        url = check_viewer_url(viewer)
        if not reachable(url):
            warn(f'no Rerun viewer answers at {url}; saving the .rrd only')
            url = None
    if spawn and not has_display(environ):
        warn('viewer:=spawn without a display (DISPLAY and WAYLAND_DISPLAY are unset): '
             'no viewer spawned; saving the .rrd only')
        spawn = False
    elif spawn and not port_free(port):
        warn(f'{LOOPBACK}:{port} is taken (another viewer?): no viewer spawned; saving the '
             f'.rrd only (set viewer_port, or connect with viewer:={server_url(port)})')
        spawn = False
    if not rrd_path and url is None:
        rrd_path = default_rrd_path()
    return url, (check_rrd_path(rrd_path) if rrd_path else None), spawn


def open_recording(recording_id, url, rrd_path, strict=False, server_port=None):
    """Open an ``rr.RecordingStream`` with the chosen sinks and the default blueprint.

    ``server_port``: also host a gRPC server on 127.0.0.1 there (for a spawned viewer).
    """
    if strict:
        rr.set_strict_mode(True)
    recording = rr.RecordingStream(APPLICATION_ID, recording_id=recording_id)
    sinks = []
    if rrd_path is not None:
        sinks.append(rr.FileSink(str(rrd_path)))
    if url is not None:
        sinks.append(rr.GrpcSink(url))
    if server_port is not None:
        sinks.append(rr.GrpcServerSink(LOOPBACK, server_port,
                                       server_memory_limit=SERVER_MEMORY_LIMIT))
    recording.set_sinks(*sinks, default_blueprint=facade_blueprint())
    return recording


def close_recording(recording, warn):
    """Send what is left to the sinks (bounded wait: a viewer may be gone) and close them."""
    try:
        recording.flush(timeout_sec=FLUSH_TIMEOUT_S)
    except RuntimeError as error:
        warn(f'not everything reached the viewer within {FLUSH_TIMEOUT_S:g} s ({error})')
    recording.disconnect()
