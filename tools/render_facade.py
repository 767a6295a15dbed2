"""Render PNG pictures of the facade at chosen times of a recorded day, headless.

The input is a Rerun ``.rrd`` file written by the bridge (timeline ``ros_time``, the folded
panels as one mesh, ``/facade/panels``). The script starts the native Rerun viewer headless on
127.0.0.1, opens the file, moves the time cursor to each requested local clock time, waits until
the 3D view has stopped changing, and writes ``<out>/facade_<HHMM>.png``.

Requirements:

* rerun-sdk 0.41 in the venv (it ships the viewer binary ``rerun_cli/rerun``);
* a Vulkan software renderer, since there is no GPU or display: as root,
  ``apt-get install mesa-vulkan-drivers libvulkan1`` (Debian 12: lavapipe/llvmpipe).

Usage (from the repository root)::

    .venv/bin/python tools/render_facade.py /path/facade.rrd --at 12:10 12:30 --out docs/
    .venv/bin/python tools/render_facade.py facade.rrd --at start end --view 3d --size 1600x900

``--at`` takes local clock times ``HH:MM`` on the recording's date (or ``--date``) in the UTC
offset ``--utc-offset`` (default: the demonstrator facade YAML's ``site.utc_offset_h``), or
``start``/``end``. ``--view 3d`` replaces the recording's blueprint (3D view and plots) with the
3D view alone, seen from the south-west (``--eye``/``--target`` move the camera).

The viewer child gets a private temporary XDG_CONFIG_HOME/XDG_DATA_HOME/XDG_CACHE_HOME and TMPDIR
with analytics disabled, so nothing is written under ``~``; it is killed by its PID at the end.
"""

import argparse
import datetime as dt
import io
import os
from pathlib import Path
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import time

import numpy as np
from PIL import Image
import pyarrow as pa
import rerun as rr
from rerun.experimental import ViewerClient

TIMELINE = 'ros_time'
MESHES = '/facade/panels/**'
DEFAULT_EYE = (-4.6, -6.2, 2.4)
DEFAULT_TARGET = (0.0, 0.0, -0.2)
TOLERANCE_NS = 60 * 10**9
"""A requested time this close outside the recording is clamped to its first or last sample."""


def default_utc_offset():
    """UTC offset [h] of the demonstrator facade YAML, or 2.0 if it cannot be read."""
    try:
        from flectofold_model.facade.description import DEFAULT_FACADE, load_facade
    except ImportError:
        sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
        try:
            from flectofold_model.facade.description import DEFAULT_FACADE, load_facade
        except ImportError:
            return 2.0
    try:
        return float(load_facade(DEFAULT_FACADE).utc_offset_h)
    except Exception:  # noqa: B902 - any unreadable YAML falls back to the default
        return 2.0


def parse_args(argv=None):
    parser = argparse.ArgumentParser(
        description='Render PNG pictures of the facade from a Rerun .rrd file (headless).')
    parser.add_argument('rrd', type=Path, help='recording written by the bridge')
    parser.add_argument('--at', nargs='+', required=True, metavar='HH:MM',
                        help='local clock times, or "start" / "end"')
    parser.add_argument('--utc-offset', type=float, default=None,
                        help='local time offset from UTC [h] (default: facade YAML, else 2)')
    parser.add_argument('--date', type=dt.date.fromisoformat, default=None,
                        help="local date YYYY-MM-DD (default: the recording's date)")
    parser.add_argument('--out', type=Path, default=Path('docs'), help='output folder')
    parser.add_argument('--size', default='1600x900', help='viewer window WIDTHxHEIGHT')
    parser.add_argument('--port', type=int, default=19876, help='viewer gRPC port on 127.0.0.1')
    parser.add_argument('--view', choices=('default', '3d'), default='default',
                        help="default: the recording's blueprint; 3d: the 3D view alone")
    parser.add_argument('--eye', type=float, nargs=3, default=DEFAULT_EYE, metavar='M',
                        help='camera position x y z [m] for --view 3d (ENU)')
    parser.add_argument('--target', type=float, nargs=3, default=DEFAULT_TARGET, metavar='M',
                        help='camera look-at point x y z [m] for --view 3d')
    parser.add_argument('--settle', type=float, default=3.0,
                        help='seconds to wait after moving the time cursor')
    args = parser.parse_args(argv)
    if not re.fullmatch(r'\d+x\d+', args.size):
        parser.error(f'--size must look like 1600x900, got {args.size!r}')
    for text in args.at:
        if text not in ('start', 'end') and not re.fullmatch(r'\d{1,2}:\d{2}', text):
            parser.error(f'--at: expected HH:MM, start or end, got {text!r}')
    if not args.rrd.is_file():
        parser.error(f'no such file: {args.rrd}')
    if args.utc_offset is None:
        args.utc_offset = default_utc_offset()
    return args


def recording_range_ns(path):
    """First and last ``ros_time`` [ns since the epoch] of the panel meshes in ``path``."""
    store = rr.chunk.RrdReader(str(path)).store()
    chunks = store.stream().filter(content=MESHES, has_timeline=TIMELINE).to_chunks()
    times = [chunk.to_record_batch().column(TIMELINE).cast(pa.int64()).to_numpy()
             for chunk in chunks]
    if not times:
        raise SystemExit(f'{path}: no {MESHES} data on the {TIMELINE!r} timeline')
    times = np.concatenate(times)
    return int(times.min()), int(times.max())


def to_local(ns, tz):
    return dt.datetime.fromtimestamp(ns / 1e9, tz)


def resolve_time(text, date, tz, first_ns, last_ns):
    """``(ns, label)`` for one ``--at`` value; exits with a message if outside the recording."""
    if text in ('start', 'end'):
        ns = first_ns if text == 'start' else last_ns
        return ns, to_local(ns, tz).strftime('%H%M')
    hour, minute = (int(part) for part in text.split(':'))
    if hour > 23 or minute > 59:
        raise SystemExit(f'--at {text}: not a clock time')
    moment = dt.datetime.combine(date, dt.time(hour, minute), tz)
    ns = int(moment.timestamp()) * 10**9
    if not first_ns - TOLERANCE_NS <= ns <= last_ns + TOLERANCE_NS:
        span = f'{to_local(first_ns, tz):%Y-%m-%d %H:%M:%S} .. {to_local(last_ns, tz):%H:%M:%S}'
        raise SystemExit(f'--at {text} ({moment:%Y-%m-%d %H:%M %Z}) lies outside the '
                         f'recording ({span} {tz})')
    return min(max(ns, first_ns), last_ns), f'{hour:02d}{minute:02d}'


def viewer_binary():
    import rerun_cli
    binary = Path(rerun_cli.__file__).with_name('rerun')
    if not binary.is_file():
        raise SystemExit(f'viewer binary not found: {binary}')
    return binary


def check_port_free(port):
    with socket.socket() as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # ignore TIME_WAIT
        try:
            probe.bind(('127.0.0.1', port))
        except OSError:
            raise SystemExit(f'port {port} on 127.0.0.1 is in use; pick another with --port')


def viewer_env(scratch):
    """Environment for the viewer child: private XDG folders and TMPDIR, Vulkan backend."""
    env = dict(os.environ, WGPU_BACKEND='vulkan')
    for name, sub in (('XDG_CONFIG_HOME', 'config'), ('XDG_DATA_HOME', 'data'),
                      ('XDG_CACHE_HOME', 'cache'), ('TMPDIR', 'tmp')):
        env[name] = str(scratch / sub)
        (scratch / sub).mkdir()
    return env


def start_viewer(binary, port, size, env, log):
    subprocess.run([str(binary), 'analytics', 'disable'], env=env, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, timeout=30, check=False)
    command = [str(binary), '--headless', '--bind', '127.0.0.1', '--port', str(port),
               '--window-size', size, '--hide-welcome-screen']
    return subprocess.Popen(command, env=env, stdout=log, stderr=subprocess.STDOUT,
                            stdin=subprocess.DEVNULL)


def connect(process, port, log_path, timeout_s=30.0):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if process.poll() is not None:
            tail = Path(log_path).read_text(errors='replace')[-2000:]
            raise SystemExit(f'viewer exited with code {process.returncode}:\n{tail}\n'
                             'Is mesa-vulkan-drivers installed?')
        try:
            client = ViewerClient.connect(f'rerun+http://127.0.0.1:{port}/proxy')
            client.get_state()
            return client
        except Exception:  # noqa: B902 - the viewer is not listening yet
            time.sleep(0.2)
    raise SystemExit(f'viewer did not answer on 127.0.0.1:{port} within {timeout_s:g} s')


def open_recording(client, path, timeout_s=60.0):
    client.open(str(path.resolve()))
    deadline = time.monotonic() + timeout_s
    while client.get_state().loading:
        if time.monotonic() > deadline:
            raise SystemExit(f'viewer still loading {path} after {timeout_s:g} s')
        time.sleep(0.2)


def view_3d_id(client):
    views = [view.view_id for view in client.get_state().views if view.view_class == '3D']
    if not views:
        raise SystemExit("the recording's blueprint has no 3D view")
    return views[0]


def show_3d_only(client, view_id, eye, target):
    """Replace the blueprint with the 3D view alone, with an orbital eye at ``eye``."""
    blueprint = client.get_blueprint().blueprint
    kept = {key: value for key, value in blueprint.items()
            if not key.startswith(('/view/', '/container/', '/viewport'))
            or key.startswith(f'/view/{view_id}')}
    root = '5f0c0de5-3d00-4a11-8e00-000000000001'
    kept[f'/container/{root}'] = {'ContainerBlueprint': {
        'container_kind': 'Horizontal', 'contents': [f'/view/{view_id}'], 'visible': True}}
    kept['/viewport'] = {'ViewportBlueprint': {'root_container': root}}
    kept[f'/view/{view_id}/EyeControls3D'] = {'EyeControls3D': {
        'kind': 'Orbital', 'position': list(eye), 'look_target': list(target),
        'eye_up': [0.0, 0.0, 1.0]}}
    client.set_blueprint(kept, of='recording')


def pixels(png):
    return np.asarray(Image.open(io.BytesIO(png)).convert('L'), dtype=np.float32)


def looks_empty(image):
    """Tell whether the 3D view is nearly uniform (grid lines only): too few lit pixels."""
    return image.std() < 12.0 or (image > 90.0).mean() < 0.03


def wait_for_scene(client, view_id, attempts=10, pause_s=1.0):
    """Return a viewer screenshot once the 3D view is non-empty and two shots agree.

    Chunks of an opened ``.rrd`` load on demand, so the first frames after a time jump may show
    a half-loaded scene; the viewer is shot again ``pause_s`` later until nothing changes.
    """
    previous = None
    for _ in range(attempts):
        png = client.take_screenshot()
        image = pixels(png)
        if previous is not None and image.shape == previous.shape \
                and np.abs(image - previous).mean() < 0.2 \
                and not looks_empty(pixels(client.take_screenshot(view_id))):
            return png
        previous = image
        time.sleep(pause_s)
    print('warning: the viewer still looks empty or unsettled; writing the last shot',
          file=sys.stderr)
    return png


def shoot(client, view_id, ns, out_path, settle_s):
    client.set_time(TIMELINE, timestamp=np.datetime64(ns, 'ns'), play_state='paused')
    time.sleep(settle_s)
    out_path.write_bytes(wait_for_scene(client, view_id))


def render(args, shots):
    binary = viewer_binary()
    check_port_free(args.port)
    args.out.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix='render_facade_'))
    log_path = scratch / 'viewer.log'
    process = None
    try:
        with open(log_path, 'w') as log:
            process = start_viewer(binary, args.port, args.size, viewer_env(scratch), log)
            client = connect(process, args.port, log_path)
            open_recording(client, args.rrd)
            view_id = view_3d_id(client)
            if args.view == '3d':
                show_3d_only(client, view_id, args.eye, args.target)
            for ns, label in shots:
                start = time.monotonic()
                out_path = args.out / f'facade_{label}.png'
                shoot(client, view_id, ns, out_path, args.settle)
                print(f'{out_path} ({time.monotonic() - start:.1f} s)')
    finally:
        if process is not None:
            process.kill()
            process.wait(timeout=10)
        shutil.rmtree(scratch, ignore_errors=True)


def main(argv=None):
    args = parse_args(argv)
    tz = dt.timezone(dt.timedelta(hours=args.utc_offset))
    first_ns, last_ns = recording_range_ns(args.rrd)
    date = args.date or to_local(first_ns, tz).date()
    shots = [resolve_time(text, date, tz, first_ns, last_ns) for text in args.at]
    render(args, shots)


if __name__ == '__main__':
    main()
