"""The structural path in Rerun: the folded sheet at every equilibrium, coloured by strain.

No rclpy here. ``fold_table --model structural --rrd FILE`` writes it
(:func:`save_structural_path`). Entity layout
(timeline ``equilibrium``, the index of the equilibrium along the path, 0 the moulded open
state; panel frame, z out of the facade, REP-103):

- ``/structure/sheet``: one ``Mesh3D``: triangles static (with ``zone`` per triangle, 0 mid-rib
  or central part, 1 hinge, 2 flap, and the ``allowable_strain``), vertex positions [m] and
  vertex colours at every equilibrium. A vertex takes the largest surface strain of the
  triangles around it, coloured by :func:`~flectofold_ros.wire.colours.strain_colours` (green none,
  amber the allowable, red ten times it).
- ``/structure/pressure_pa``, ``/structure/apex_fold_rad``, ``/structure/peak_hinge_strain``:
  one scalar per equilibrium.
"""

import numpy as np
import rerun as rr

from flectofold_ros.wire.colours import strain_colours

TIMELINE = 'equilibrium'
SHEET = '/structure/sheet'
#: The scalar series: entity name and the path's field.
SERIES = (('/structure/pressure_pa', 'pressure_pa'), ('/structure/apex_fold_rad', 'apex_fold_rad'))
PEAK_HINGE_STRAIN = '/structure/peak_hinge_strain'


def vertex_strain(triangles, triangle_strain, node_count):
    """Largest strain of the triangles around each node ``(..., nodes)``."""
    strain = np.asarray(triangle_strain, dtype=float)
    result = np.zeros(strain.shape[:-1] + (node_count,))
    for corner in range(3):
        np.maximum.at(result, (..., np.asarray(triangles)[:, corner]), strain)
    return result


def log_structural_path(recording, path, allowable_strain):
    """Log a :class:`~flectofold_model.structure.panel.StructuralPath` to ``recording``.

    The path must carry its meshes (``positions_m``, ``surface_strain``, ``triangles``, as
    :func:`~flectofold_model.structure.panel.structural_path` gives them).
    """
    if path.positions_m is None or path.surface_strain is None or path.triangles is None:
        raise ValueError('the path carries no meshes (positions_m, surface_strain, triangles)')
    recording.log('/', rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    triangles = np.asarray(path.triangles, dtype=np.uint32)
    recording.log(SHEET, rr.Mesh3D.from_fields(triangle_indices=triangles), static=True)
    recording.log(SHEET, rr.AnyValues(zone=np.asarray(path.zone, dtype=np.int32),
                                      allowable_strain=[float(allowable_strain)]), static=True)
    node_count = path.positions_m.shape[1]
    strain = vertex_strain(path.triangles, path.surface_strain, node_count)
    for index, positions in enumerate(path.positions_m):
        recording.set_time(TIMELINE, sequence=index)
        colours = strain_colours(strain[index], allowable_strain)
        recording.log(SHEET, rr.Mesh3D.from_fields(
            vertex_positions=np.asarray(positions, dtype=np.float32),
            vertex_colors=colours))
        for entity, field in SERIES:
            recording.log(entity, rr.Scalars(float(getattr(path, field)[index])))
        recording.log(PEAK_HINGE_STRAIN, rr.Scalars(float(path.peak_strain['hinge'][index])))


def save_structural_path(rrd_path, path, allowable_strain):
    """Write :func:`log_structural_path` of ``path`` to the .rrd file ``rrd_path``."""
    recording = rr.RecordingStream('flectofold_structure')
    recording.set_sinks(rr.FileSink(str(rrd_path)))
    log_structural_path(recording, path, allowable_strain)
    recording.flush()
    recording.disconnect()
