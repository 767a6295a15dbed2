"""Export a facade's folded panels to CAD: OBJ, glTF or GLB, in the site frame, metres.

``ros2 run flectofold_ros facade_export --facade FILE_OR_NAME --closure C --out PATH`` (or
``facade_export`` in the venv). The closure is one value for every panel (0 open, 1 closed,
through the fold model's own map to each panel's fold angle), or ``--time``: what the
facade's own schedule commands at that instant of a clear day (see
``flectofold_model.scheduling.scheduled_closure``). ``--surface-quads PATH.obj`` also writes
the facade's surface as the quad mesh that ``surface: {type: obj}`` reads back.
"""

import argparse
from datetime import datetime, timedelta, timezone
from pathlib import Path
import sys
import time

FRAMES = """frames and units (metres everywhere):
  .obj          site_enu as is: x east, y north, z up; one object (o) per panel id
  .gltf / .glb  glTF is Y-up: (east, north, up) -> (east, up, -north); one node and mesh
                per panel, named by its panel id (a Z-up importer such as Blender's gives
                back east, north, up)
  --surface-quads OBJ: the facade frame, x along the facade (right seen from outside),
                y up, z out: the frame a facade description's OBJ surface is read in
--time: ISO 8601, e.g. 2026-06-21T12:00:00+02:00 or ...Z; without an offset the facade's
  own clock (site.utc_offset_h). The schedule runs from that local midnight under a clear
  sky, one decision every control.period_s."""


def main(args=None):
    from flectofold_ros.runtime.runner import run_command
    parser = argparse.ArgumentParser(
        prog='facade_export', description=__doc__.splitlines()[0], epilog=FRAMES,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--facade', default=None,
                        help='facade description YAML or embedded name (default: the 6x6 '
                             'demonstrator; hexagon_6x6: its hexagonal counterpart)')
    state = parser.add_mutually_exclusive_group()
    state.add_argument('--closure', type=float, default=None,
                       help='closure of every panel, 0 (open) to 1 (closed)')
    state.add_argument('--time', default=None,
                       help="the schedule's closures at this instant (ISO 8601)")
    parser.add_argument('--out', type=Path, default=None,
                        help='folded panels to PATH.obj, PATH.gltf or PATH.glb')
    parser.add_argument('--surface-quads', type=Path, default=None,
                        help='the surface quad mesh (one quad per panel) to PATH.obj')
    options = parser.parse_args((sys.argv if args is None else args)[1:])
    return run_command('facade_export', lambda stop: export(options), interrupted_code=130)


def export(options):
    """Check the options, load the facade, write the files; print what was written."""
    from flectofold_model.facade import DEFAULT_FACADE, load_facade
    from flectofold_model.facade.mesh_files import mesh_format
    if options.out is None and options.surface_quads is None:
        raise ValueError('nothing to write: give --out, --surface-quads or both')
    if options.out is not None:
        if options.closure is None and options.time is None:
            raise ValueError('--out needs --closure C or --time ISO8601')
        mesh_format(options.out)
        _check_folder(options.out)
    if options.surface_quads is not None:
        if options.surface_quads.suffix.lower() != '.obj':
            raise ValueError(f'{options.surface_quads}: --surface-quads writes an .obj file')
        _check_folder(options.surface_quads)
    if options.closure is not None and not 0.0 <= options.closure <= 1.0:  # NaN fails too
        raise ValueError(f'--closure must lie in [0, 1], got {options.closure:g}')
    name = DEFAULT_FACADE if options.facade is None else options.facade
    facade = load_facade(name)
    epoch_s = None if options.time is None else parse_time(options.time, facade.utc_offset_h)
    print(f'facade_export: {facade.name}: {len(facade)} {facade.panel_kind} panels')
    if options.out is not None:
        _write_folded(facade, options, epoch_s)
    if options.surface_quads is not None:
        _write_surface(name, options.surface_quads)
    return 0


def parse_time(text, utc_offset_h):
    """POSIX time [s] of an ISO 8601 instant; without an offset, on a clock at ``utc_offset_h``."""
    try:
        instant = datetime.fromisoformat(text)
    except ValueError:
        raise ValueError(f'--time: not an ISO 8601 date and time: {text!r} (e.g. '
                         f'2026-06-21T12:00:00+02:00)') from None
    if instant.tzinfo is None:
        instant = instant.replace(tzinfo=timezone(timedelta(hours=utc_offset_h)))
    return instant.timestamp()


def _check_folder(path):
    if not path.parent.is_dir():
        raise ValueError(f'{path}: folder {path.parent} does not exist')
    if path.is_dir():
        raise ValueError(f'{path}: is a folder')


def _write_folded(facade, options, epoch_s):
    from flectofold_model.facade.folded_mesh import folded_meshes
    from flectofold_model.facade.mesh_files import write_meshes
    from flectofold_model.scheduling.scheduled_closure import scheduled_closure
    if epoch_s is None:
        closure, source = options.closure, f'closure {options.closure:g}'
    else:
        started = time.perf_counter()
        print('facade_export: replaying the schedule from the midnight before (shading table '
              'and every decision: about 15 s)', flush=True)
        closure = scheduled_closure(facade, epoch_s)
        when = datetime.fromtimestamp(epoch_s, timezone.utc).isoformat()
        source = f'scheduled closures at {when} (clear sky)'
        print(f'schedule: closure min {closure.min():.2f}, mean {closure.mean():.2f}, '
              f'max {closure.max():.2f} at {when} ({time.perf_counter() - started:.1f} s)')
    started = time.perf_counter()
    meshes = folded_meshes(facade, closure=closure)
    comments = [f'flectofold facade_export: {facade.name}, {len(meshes)} {facade.panel_kind} '
                f'panels, {source}']
    path = _written(lambda: write_meshes(meshes, options.out, comments), options.out)
    vertices = sum(len(mesh.vertices_m) for mesh in meshes)
    triangles = sum(len(mesh.faces) for mesh in meshes)
    print(f'folded panels: {path.resolve()} ({path.stat().st_size:,} bytes, {len(meshes)} '
          f'panels, {vertices:,} vertices, {triangles:,} triangles, '
          f'{time.perf_counter() - started:.2f} s)')


def _write_surface(name, path):
    from flectofold_model.facade.description import surface_quads
    from flectofold_model.facade.mesh_files import write_quad_obj
    vertices, quads = surface_quads(name)
    comments = [f'flectofold facade_export --surface-quads: {Path(str(name)).name}']
    written = _written(lambda: write_quad_obj(vertices, quads, path, comments), path)
    print(f'surface quads: {written.resolve()} ({len(quads)} quads, {len(vertices)} vertices)')


def _written(write, path):
    """Run ``write()``; an error of the file system is bad input (a path it cannot use)."""
    try:
        return write()
    except OSError as error:
        raise ValueError(f'{path}: cannot write: {error.strerror or error}') from None


if __name__ == '__main__':
    sys.exit(main())
