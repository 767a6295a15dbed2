"""Read back what a Rerun .rrd holds, for assertions (``rr.chunk.RrdReader``, no extras)."""

import numpy as np
import rerun as rr

TIMELINE = 'ros_time'


class Rrd:
    """The recording of one .rrd file, compacted in memory."""

    def __init__(self, path):
        self.reader = rr.chunk.RrdReader(str(path))
        self.store = self.reader.stream().collect()

    def entities(self):
        return set(self.reader.store().schema().entity_paths())

    def rows(self, entity, component):
        """``[(ros_time_ns, value), ...]`` of a component at an entity, in time order."""
        rows = []
        for chunk in self.store.stream().filter(content=entity).to_chunks():
            if chunk.entity_path != entity:
                continue
            batch = chunk.to_record_batch()
            if component not in batch.schema.names or TIMELINE not in batch.schema.names:
                continue
            times = batch.column(TIMELINE).cast('int64').to_numpy(zero_copy_only=False)
            values = batch.column(component).to_pylist()
            rows += [(int(t), v) for t, v in zip(times, values) if v is not None]
        return sorted(rows, key=lambda row: row[0])

    def static(self, entity, component):
        """Return the static value of a component at an entity, or None."""
        for chunk in self.store.stream().filter(content=entity).to_chunks():
            batch = chunk.to_record_batch()
            if chunk.entity_path == entity and component in batch.schema.names and \
                    TIMELINE not in batch.schema.names:
                return batch.column(component).to_pylist()[-1]
        return None

    def vertices(self, panel_id):
        """``[(ros_time_ns, (V, 3) array), ...]`` of a panel's mesh."""
        return [(t, np.array(v)) for t, v in
                self.rows(f'/facade/panels/{panel_id}/mesh', 'Mesh3D:vertex_positions')]

    def series(self, name, panel_id):
        """``[(ros_time_ns, value), ...]`` of a panel's time series."""
        return [(t, v[0]) for t, v in self.rows(f'/metrics/{name}/{panel_id}', 'Scalars:scalars')]


def latest_at(rows, time_ns):
    """Return the value of ``rows`` at ``time_ns`` (the last row at or before it)."""
    value = None
    for t, v in rows:
        if t > time_ns:
            break
        value = v
    return value
