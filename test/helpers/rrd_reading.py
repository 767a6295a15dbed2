"""Read back what a Rerun .rrd holds, for assertions (``rr.chunk.RrdReader``, no extras).

The bridge's layout (``msg_docs/rerun_bridge.md``): one batched mesh ``/facade/panels`` whose
static ``panel_id`` and ``vertices_per_panel`` say which vertices are whose, and one entity per
time series, ``/metrics/<name>``, with one scalar per panel per row, named by the static
``SeriesLines:names``.
"""

import numpy as np
import rerun as rr

TIMELINE = 'ros_time'
PANELS = '/facade/panels'


class Rrd:
    """The recording of one .rrd file, compacted in memory."""

    def __init__(self, path, timeline=TIMELINE):
        self.timeline = timeline
        self.reader = rr.chunk.RrdReader(str(path))
        self.store = self.reader.stream().collect()

    def entities(self):
        return set(self.reader.store().schema().entity_paths())

    def _batches(self, entity, component, temporal):
        for chunk in self.store.stream().filter(content=entity).to_chunks():
            if chunk.entity_path != entity:
                continue
            batch = chunk.to_record_batch()
            timed = self.timeline in batch.schema.names
            if component in batch.schema.names and timed == temporal:
                yield batch

    def rows(self, entity, component):
        """``[(ros_time_ns, value), ...]`` of a component at an entity, in time order.

        Values are Python lists (``to_pylist``); rows logged at the same time keep the order
        they were logged in.
        """
        rows = []
        for batch in self._batches(entity, component, temporal=True):
            times = batch.column(self.timeline).cast('int64').to_numpy(zero_copy_only=False)
            values = batch.column(component).to_pylist()
            order = batch.column(0).to_pylist()  # the row ids: logging order
            rows += [(int(t), o, v) for t, o, v in zip(times, order, values) if v is not None]
        return [(t, v) for t, _, v in sorted(rows, key=lambda row: (row[0], row[1]))]

    def arrays(self, entity, component, width=None):
        """``[(ros_time_ns, numpy array), ...]``: :meth:`rows` as flat arrays, fast.

        ``width`` (3 for vectors) reshapes each row to ``(-1, width)``.
        """
        rows = []
        for batch in self._batches(entity, component, temporal=True):
            times = batch.column(self.timeline).cast('int64').to_numpy(zero_copy_only=False)
            order = batch.column(0).to_pylist()
            column = batch.column(component)
            for j in range(len(column)):
                if not column[j].is_valid:
                    continue
                values = column[j].values
                if width is not None:
                    values = values.flatten()
                array = values.to_numpy(zero_copy_only=False)
                rows.append((int(times[j]), order[j],
                             array if width is None else array.reshape(-1, width)))
        return [(t, a) for t, _, a in sorted(rows, key=lambda row: (row[0], row[1]))]

    def static(self, entity, component):
        """Return the static value of a component at an entity, or None."""
        for batch in self._batches(entity, component, temporal=False):
            return batch.column(component).to_pylist()[-1]
        return None

    # -- the bridge's layout ----------------------------------------------------------------

    def panel_ids(self):
        """Return the panel ids in the order of the facade mesh's vertex blocks."""
        return self.static(PANELS, 'panel_id')

    def vertices_per_panel(self):
        return self.static(PANELS, 'vertices_per_panel')[0]

    def meshes(self, component='Mesh3D:vertex_positions'):
        """``[(ros_time_ns, (N, V, 3) or (N, V) array), ...]`` of the facade mesh."""
        count, size = len(self.panel_ids()), self.vertices_per_panel()
        width = None if component == 'Mesh3D:vertex_colors' else 3
        shape = (count, size) if width is None else (count, size, 3)
        return [(t, a.reshape(shape)) for t, a in self.arrays(PANELS, component, width)]

    def vertices(self, panel_id):
        """``[(ros_time_ns, (V, 3) world vertices), ...]`` of one panel."""
        i = self.panel_ids().index(panel_id)
        return [(t, a[i]) for t, a in self.meshes()]

    def colours(self, panel_id):
        """``[(ros_time_ns, packed 0xRRGGBBAA), ...]`` of one panel (its first vertex)."""
        i = self.panel_ids().index(panel_id)
        return [(t, int(a[i, 0])) for t, a in self.meshes('Mesh3D:vertex_colors')]

    def series_table(self, name):
        """``(names, stamps_ns, (R, N) values)`` of ``/metrics/<name>``."""
        entity = f'/metrics/{name}' if not name.startswith('/') else name
        names = self.static(entity, 'SeriesLines:names')
        rows = self.arrays(entity, 'Scalars:scalars')
        values = np.array([a for _, a in rows]).reshape(len(rows), len(names))
        return names, np.array([t for t, _ in rows], dtype=np.int64), values

    def series(self, name, panel_id):
        """``[(ros_time_ns, value), ...]`` of one panel's series, rows with a number only."""
        names, stamps, values = self.series_table(name)
        column = values[:, names.index(panel_id)]
        return [(int(t), float(v)) for t, v in zip(stamps, column) if np.isfinite(v)]


def latest_at(rows, time_ns):
    """Return the value of ``rows`` at ``time_ns`` (the last row at or before it)."""
    value = None
    for t, v in rows:
        if t > time_ns:
            break
        value = v
    return value
