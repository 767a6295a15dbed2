"""The facade in Rerun: every panel folded in one batched mesh, the sun, series and events.

No rclpy here. The live ``rerun_bridge`` node and the offline bag converter (``replay
--to-rrd``) feed the same :class:`FacadeScene` with plain values, so a bag converted later
gives the recording the live bridge gave.

The input is ``/facade/panel_states`` (:mod:`flectofold_ros.wire.panel_states`): one message per
panel process and state instant, a table of that process's panels. The scene logs a constant
number of Rerun calls per flush whatever the panel count (one mesh, one column batch per time
series, one for the events), so 1,000 panels cost about what 36 do in calls; the data is kept
small by a facade-scale mesh resolution (:func:`facade_topology`).

Entity layout (timeline ``ros_time``, a timestamp from the message stamps; world frame = the
site's ENU frame, z up, REP-103), documented with what is logged when in
``msg_docs/rerun_bridge.md``:

- ``/facade/surface``: the facade surface, one facet per patch (static).
- ``/facade/panels``: ONE ``Mesh3D`` of all panels, vertices in world coordinates, panel ``i``
  owning vertices ``[i V, (i + 1) V)`` (``V`` static as ``vertices_per_panel``, the ids as
  ``panel_id``). Triangles static; positions and normals when a panel moved more than
  ``min_change_rad``; vertex colours when a panel's colour changed.
- ``/facade/panel_frames``: each panel's origin (``Points3D`` labelled with its id) and its
  frame (``panel_to_enu``, 9 numbers per panel, row-major), static.
- ``/sun``: an arrow from the sun toward the facade (cleared below the horizon).
- ``/metrics/closure``, ``/metrics/pressure_gauge_pa``, ``/metrics/fold_angle_rad``: one scalar
  per panel per row (series named by the panel ids); ``/metrics/closure_mean``: the facade's
  mean closure and its min and max, three series.
- ``/facade/events``: text log of panel status and fault changes.

Inputs are checked: an unknown panel id or a non-finite value is counted in ``rejected`` and
not logged, so a bad message never corrupts the recording.
"""

from dataclasses import dataclass

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from flectofold_model.actuation import ATMOSPHERIC_PRESSURE_PA
# The facade's folded mesh in the site frame has one implementation, shared with the CAD
# export; its resolution rule and k_from_sag are re-exported here for the scene's callers.
from flectofold_model.facade.folded_mesh import (  # noqa: F401
    facade_topology, FACADE_VERTEX_BUDGET, FacadeMesher, k_from_sag)
from flectofold_ros.wire import contract, panel_states
# One colour scheme for every view of the facade; re-exported for the scene's callers.
from flectofold_ros.wire.colours import (  # noqa: F401
    FAULT_RGBA, NO_STATE_RGBA, panel_colours, ramp_colour, ramp_colours, SURFACE_RGBA)

TIMELINE = 'ros_time'
COLOR_MODES = ('closure', 'pressure')
PANELS = '/facade/panels'
PANEL_FRAMES = '/facade/panel_frames'
SURFACE = '/facade/surface'
EVENTS = '/facade/events'
SUN = '/sun'
#: The per-panel time series: ``/metrics/<name>``, one scalar per panel per row.
SERIES = ('closure', 'pressure_gauge_pa', 'fold_angle_rad')
CLOSURE_MEAN = '/metrics/closure_mean'
#: The series of ``/metrics/closure_mean``, in the order of each row's three scalars.
CLOSURE_BAND = ('mean', 'min', 'max')
#: Gauge pressure at the dark end of the pressure colour ramp [Pa].
PRESSURE_FULL_SCALE_PA = 12e3
_BAND_COLOURS = [(24, 78, 104, 255), (122, 170, 160, 255), (122, 170, 160, 255)]
SUN_ARROW_M = 3.0
#: How far a panel state's position may be from its panel's origin in the facade [m]: the
#: states carry positions in float32 (about 1 um at 10 m); a state farther off belongs to
#: another facade.
PLACEMENT_TOLERANCE_M = 0.01


@dataclass
class SceneCounts:
    """What a scene has taken and logged so far."""

    states_taken: int = 0
    """Panel states (one panel in one message) accepted."""
    meshes_logged: int = 0
    """Facade meshes logged (new vertex positions of ``/facade/panels``)."""
    panels_remeshed: int = 0
    """Panel meshes rebuilt for them (the panels that moved)."""
    panels_unchanged: int = 0
    """Panel states not re-meshed because the fold angle moved less than the threshold."""
    colours_logged: int = 0
    samples_logged: int = 0
    """Scalars logged to the per-panel series (one per panel, quantity and row)."""
    events_logged: int = 0
    rejected: int = 0
    """Messages that are not panel states; panel states of unknown panels, misplaced or with
    non-finite values; bad sun vectors. Dropped."""
    misplaced: int = 0
    """Panel states whose position is not where this facade puts that panel: states of
    another facade (a bag recorded with one, converted with another). Dropped."""


def facade_blueprint():
    """Return the default layout: the 3D facade left; plots and the status log right.

    The plots show the whole recording (a day is the scale a facade is judged on); the
    time cursor marks the moment the 3D view shows.
    """
    whole = rrb.TimeAxis(view_range=rrb.TimeRange(start=rrb.TimeRangeBoundary.infinite(),
                                                  end=rrb.TimeRangeBoundary.infinite()))
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(origin='/', contents=['/facade/**', '/sun/**'], name='Facade 3D'),
            rrb.Vertical(
                rrb.Tabs(
                    rrb.TimeSeriesView(origin=CLOSURE_MEAN,
                                       name='Closure: facade mean, min, max [-]', axis_x=whole),
                    rrb.TimeSeriesView(origin='/metrics/closure', name='Closure [-]',
                                       axis_x=whole),
                    rrb.TimeSeriesView(origin='/metrics/pressure_gauge_pa',
                                       name='Cushion pressure [Pa gauge]', axis_x=whole),
                ),
                rrb.TimeSeriesView(origin='/metrics/fold_angle_rad', name='Fold angle [rad]',
                                   axis_x=whole),
                rrb.TextLogView(origin=EVENTS, name='Faults and status'),
                row_shares=[2, 2, 1]),
            column_shares=[3, 2]),
        collapse_panels=True)


def packed(rgba):
    """Rerun's packed ``0xRRGGBBAA`` of (..., 4) uint8 colours."""
    rgba = np.asarray(rgba, dtype=np.uint32)
    return (rgba[..., 0] << 24) | (rgba[..., 1] << 16) | (rgba[..., 2] << 8) | rgba[..., 3]


@dataclass(frozen=True)
class _Update:
    """One panel_states message, reduced to the valid points of known panels."""

    stamp_ns: int
    index: np.ndarray
    closure: np.ndarray
    fold_angle_rad: np.ndarray
    gauge_pa: np.ndarray
    fault: np.ndarray
    status: np.ndarray

    def series(self, name):
        return {'closure': self.closure, 'pressure_gauge_pa': self.gauge_pa,
                'fold_angle_rad': self.fold_angle_rad}[name]


class FacadeScene:
    """Logs one facade to a Rerun recording; feed it panel states, call :meth:`flush` often.

    ``recording`` is an ``rr.RecordingStream`` with its sinks set. Inputs are queued; a flush
    applies them, rebuilds the meshes of the panels that moved (one vectorised ``fold_mesh``),
    and logs at most one facade mesh, one column batch per series and one for the events. Live,
    a flush shows the newest state of every panel (states between two flushes are merged in
    the mesh, never in the series). With ``every_state`` (offline conversion, where time is no
    object) a flush logs one mesh per distinct stamp it holds, in stamp order, so no state is
    merged away.
    """

    def __init__(self, facade, recording, color_by='closure', min_change_rad=1e-3,
                 every_state=False, topology=None):
        if color_by not in COLOR_MODES:
            raise ValueError(f'color_by must be one of {", ".join(COLOR_MODES)}, '
                             f'got {color_by!r}')
        if not (isinstance(min_change_rad, (int, float)) and 0.0 <= min_change_rad < 0.1):
            raise ValueError(f'min_change_rad must lie in [0, 0.1), got {min_change_rad!r}')
        self.facade, self.recording = facade, recording
        self.color_by, self.min_change_rad = color_by, float(min_change_rad)
        self.every_state = every_state
        count = len(facade)
        self.mesher = FacadeMesher(facade, topology=topology)
        self.model, self.kind = self.mesher.model, self.mesher.kind
        self.topology = self.mesher.topology
        self.panel_ids = list(facade.panel_ids)
        self._lookup = panel_states.index_lookup(self.panel_ids)
        self.positions_enu = self.mesher.positions_enu
        """(N, 3) panel origins in the site ENU frame [m]."""
        self.angle_limits_rad = self.mesher.angle_limits_rad
        # The panel state as the scene last applied it.
        self.seen = np.zeros(count, dtype=bool)
        self.stamp_ns = np.zeros(count, dtype=np.int64)
        self.fold_angle_rad = self.angle_limits_rad[0].copy()
        self.closure = np.zeros(count)
        self.gauge_pa = np.full(count, np.nan)
        self.fault = np.zeros(count, dtype=np.int16)
        self.status = np.zeros(count, dtype=np.int16)
        self._touched = np.zeros(count, dtype=bool)
        # What the recording shows: every panel meshed, at the open state until it is seen.
        self.logged_angle_rad = np.full(count, np.nan)
        self.vertices, self.normals = self.mesher.world_mesh(np.arange(count),
                                                             self.model.open_shape)
        self.logged_colour = np.zeros(count, dtype=np.uint32)
        self._positions_logged = False
        self._colours_logged = False
        # Inputs not yet flushed, and what the series and events carry between flushes.
        self._pending = []
        self._carry = {name: np.full(count, np.nan) for name in SERIES}
        self._event_codes = (np.full(count, -1, np.int16), np.full(count, -1, np.int16))
        self._events = []
        self._suns = []
        self._sun_logged_ns = None
        self.counts = SceneCounts()
        self.newest_stamp_ns = 0

    def __len__(self):
        return len(self.panel_ids)

    # -- static content ---------------------------------------------------------------------

    def log_static(self):
        """Log the frame convention, the surface, the panel frames, faces and series names."""
        rec, count = self.recording, len(self)
        rec.log('/', rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        size = self.topology.vertex_count
        faces = (self.topology.faces[None].astype(np.uint32)
                 + (size * np.arange(count, dtype=np.uint32))[:, None, None])
        rec.log(PANELS, rr.Mesh3D.from_fields(triangle_indices=faces.reshape(-1, 3)),
                static=True)
        rec.log(PANELS, rr.AnyValues(panel_id=self.panel_ids, vertices_per_panel=[size]),
                static=True)
        rec.log(PANEL_FRAMES, rr.Points3D(self.positions_enu, labels=self.panel_ids,
                                          radii=0.02, show_labels=False),
                rr.AnyValues(panel_to_enu=self.facade.panel_to_enu.reshape(-1)), static=True)
        for name in SERIES:
            rec.log(f'/metrics/{name}', rr.SeriesLines(names=self.panel_ids), static=True)
        rec.log(CLOSURE_MEAN, rr.SeriesLines(names=list(CLOSURE_BAND), colors=_BAND_COLOURS,
                                             widths=[2.0, 1.0, 1.0]), static=True)
        vertices, triangles = self.surface_facets()
        rec.log(SURFACE, rr.Mesh3D(vertex_positions=vertices, triangle_indices=triangles,
                                   albedo_factor=SURFACE_RGBA), static=True)

    def surface_facets(self, depth_m=0.05):
        """One facet per patch, ``depth_m`` behind the panels: (C N, 3) vertices and faces.

        A quad panel's patch is its rectangle (C = 4 corners), a hexagonal panel's its hexagon
        (C = 6), each a fan of C - 2 triangles.
        """
        world = self.mesher.outline_enu(depth_m)
        count, size = world.shape[:2]
        fan = np.stack([np.zeros(size - 2, int), np.arange(1, size - 1), np.arange(2, size)], -1)
        triangles = (size * np.arange(count)[:, None, None] + fan).reshape(-1, 3)
        return world.reshape(-1, 3).astype(np.float32), triangles.astype(np.uint32)

    # -- inputs -----------------------------------------------------------------------------

    def panel_indices(self, table):
        """Facade index of each point of a panel_states table; -1 for an unknown panel id."""
        return panel_states.indices(table, self._lookup)

    def panel_states(self, stamp_ns, table):
        """Take one panel_states message: ``table`` from :func:`panel_states.unpack`.

        ``stamp_ns`` is its header stamp [ns of ROS time]. Points of unknown panels, points
        more than :data:`PLACEMENT_TOLERANCE_M` from where the facade puts their panel
        (counted in ``misplaced`` too) and points with a non-finite closure or fold angle or an
        infinite pressure are counted in ``rejected`` and ignored; a NaN pressure is "no
        reading" (the gauge series shows NaN). Returns the number of panel states taken.
        """
        index = self.panel_indices(table)
        closure = table['closure'].astype(np.float64)
        angle = table['fold_angle_rad'].astype(np.float64)
        pressure = table['pressure_pa'].astype(np.float64)
        known = index >= 0
        where = np.stack([table[axis].astype(np.float64) for axis in 'xyz'], axis=-1)
        offset = np.linalg.norm(where - self.positions_enu[np.where(known, index, 0)], axis=-1)
        misplaced = known & ~(offset <= PLACEMENT_TOLERANCE_M)
        self.counts.misplaced += int(np.count_nonzero(misplaced))
        valid = (known & ~misplaced & np.isfinite(closure) & np.isfinite(angle)
                 & ~np.isinf(pressure))
        self.counts.rejected += int(len(table) - np.count_nonzero(valid))
        if not valid.any():
            return 0
        update = _Update(int(stamp_ns), index[valid], closure[valid], angle[valid],
                         pressure[valid] - ATMOSPHERIC_PRESSURE_PA,
                         table['fault'][valid].astype(np.int16),
                         table['status'][valid].astype(np.int16))
        self._note_events(update)
        self._pending.append(update)
        if update.stamp_ns > 0:  # before the first /clock, a sim-time publisher stamps 0
            self.newest_stamp_ns = max(self.newest_stamp_ns, update.stamp_ns)
        self.counts.states_taken += len(update.index)
        return len(update.index)

    def sun(self, stamp_ns, vector_enu):
        """Take the unit vector toward the sun in the site ENU frame.

        Live, a flush shows the newest; with ``every_state``, every one.
        """
        vector = np.asarray(vector_enu, dtype=float)
        if vector.shape != (3,) or not np.all(np.isfinite(vector)):
            self.counts.rejected += 1
            return
        if not self.every_state:
            self._suns.clear()
        self._suns.append((int(stamp_ns), vector))

    def _note_events(self, update):
        """Queue a text for every panel whose fault or status code differs from its last one.

        A panel's first state sets its codes; it is an event only when it reports a fault.
        (Each panel's states come from one process, in stamp order, so arrival order is its
        state order.)
        """
        faults, statuses = self._event_codes
        index = update.index
        before_fault, before_status = faults[index], statuses[index]
        fault_changed = ((update.fault != before_fault)
                         & ((before_fault >= 0) | (update.fault != 0)))
        status_changed = (update.status != before_status) & (before_status >= 0)
        for j in np.flatnonzero(fault_changed):
            code = int(update.fault[j])
            word = contract.FAULTS[code] if code < len(contract.FAULTS) else 'unknown'
            self._events.append((update.stamp_ns, f'{self.panel_ids[index[j]]} fault: {word}',
                                 'INFO' if code == 0 else 'ERROR'))
        for j in np.flatnonzero(status_changed):
            code = int(update.status[j])
            word = contract.STATUSES[code] if code < len(contract.STATUSES) else 'unknown'
            self._events.append((update.stamp_ns,
                                 f'{self.panel_ids[index[j]]} status: {word}', 'INFO'))
        faults[index], statuses[index] = update.fault, update.status

    # -- output -----------------------------------------------------------------------------

    def flush(self):
        """Log what changed since the last flush; return the number of panels re-meshed."""
        pending, self._pending = self._pending, []
        self._flush_series(pending)
        remeshed = 0
        for stamp_ns, updates in self._groups(pending):
            for update in updates:
                self._apply(update)
            remeshed += self._log_mesh(stamp_ns)
        self._flush_events()
        self._flush_sun()
        return remeshed

    def _groups(self, pending):
        if not pending:
            return []
        if not self.every_state:
            return [(max(update.stamp_ns for update in pending), pending)]
        groups = {}
        for update in sorted(pending, key=lambda update: update.stamp_ns):
            groups.setdefault(update.stamp_ns, []).append(update)
        return list(groups.items())

    def _apply(self, update):
        index = update.index
        self.fold_angle_rad[index] = update.fold_angle_rad
        self.closure[index] = update.closure
        self.gauge_pa[index] = update.gauge_pa
        self.fault[index], self.status[index] = update.fault, update.status
        self.stamp_ns[index] = update.stamp_ns
        self.seen[index] = True
        self._touched[index] = True

    def _log_mesh(self, stamp_ns):
        """Log the facade mesh at ``stamp_ns`` where panels moved or colours changed."""
        if stamp_ns <= 0:  # nothing is placed before the clock runs; the next flush shows it
            return 0
        moved = self.seen & ~(np.abs(self.fold_angle_rad - self.logged_angle_rad)
                              <= self.min_change_rad)
        self.counts.panels_unchanged += int(np.count_nonzero(self._touched & ~moved))
        self._touched[:] = False
        fields = {}
        panels = np.flatnonzero(moved)
        if len(panels):
            batch = self.mesher.batch(panels)
            shape = self.mesher.shapes(panels, self.fold_angle_rad[panels], batch)
            vertices, normals = self.mesher.world_mesh(panels, shape, batch)
            self.vertices[panels], self.normals[panels] = vertices, normals
            self.logged_angle_rad[panels] = self.fold_angle_rad[panels]
            self.counts.panels_remeshed += len(panels)
        if len(panels) or not self._positions_logged:
            # Copies: the SDK keeps a reference to the arrays until it has written them.
            fields['vertex_positions'] = self.vertices.reshape(-1, 3).copy()
            fields['vertex_normals'] = self.normals.reshape(-1, 3).copy()
            self._positions_logged = True
            self.counts.meshes_logged += 1
        colours = self.panel_colours()
        if not self._colours_logged or np.any(colours != self.logged_colour):
            fields['vertex_colors'] = np.repeat(colours, self.topology.vertex_count)
            self.logged_colour = colours
            self._colours_logged = True
            self.counts.colours_logged += 1
        if fields:
            self._at(stamp_ns)
            self.recording.log(PANELS, rr.Mesh3D.from_fields(**fields))
        return len(panels)

    def panel_colours(self):
        """Packed RGBA of every panel now: red on a fault, else closure or pressure on the ramp.

        Grey for a panel with no state yet, and (coloured by pressure) with no reading.
        """
        if self.color_by == 'pressure':
            fraction, known = self.gauge_pa / PRESSURE_FULL_SCALE_PA, np.isfinite(self.gauge_pa)
        else:
            fraction, known = self.closure, np.ones(len(self), dtype=bool)
        return packed(panel_colours(fraction, self.seen, self.fault, known))

    def _flush_series(self, pending):
        """One row per distinct stamp: every panel's value, its last one if not in the row."""
        carry = self._carry
        stamped = sorted((u for u in pending if u.stamp_ns > 0), key=lambda u: u.stamp_ns)
        for update in pending:
            if update.stamp_ns <= 0:
                for name in SERIES:
                    carry[name][update.index] = update.series(name)
        if not stamped:
            return
        stamps = np.unique([update.stamp_ns for update in stamped])
        rows = {name: np.empty((len(stamps), len(self))) for name in SERIES}
        row = 0
        for j, update in enumerate(stamped):
            for name in SERIES:
                carry[name][update.index] = update.series(name)
            if j + 1 == len(stamped) or stamped[j + 1].stamp_ns != update.stamp_ns:
                for name in SERIES:
                    rows[name][row] = carry[name]
                row += 1
        times = [rr.TimeColumn(TIMELINE, timestamp=stamps.astype('datetime64[ns]'))]
        lengths = np.full(len(stamps), len(self))
        for name in SERIES:
            self.recording.send_columns(
                f'/metrics/{name}', indexes=times,
                columns=rr.Scalars.columns(scalars=rows[name].ravel()).partition(lengths))
        self.counts.samples_logged += len(SERIES) * rows['closure'].size
        closure = rows['closure']
        finite = np.isfinite(closure)
        seen = finite.sum(axis=1)
        with np.errstate(invalid='ignore', divide='ignore'):
            mean = np.where(finite, closure, 0.0).sum(axis=1) / seen
        low = np.where(finite, closure, np.inf).min(axis=1)
        high = np.where(finite, closure, -np.inf).max(axis=1)
        band = np.stack([mean, low, high], axis=1)
        band[seen == 0] = np.nan
        self.recording.send_columns(
            CLOSURE_MEAN, indexes=times,
            columns=rr.Scalars.columns(scalars=band.ravel()).partition(
                np.full(len(stamps), len(CLOSURE_BAND))))

    def _flush_events(self):
        # States can come before the clock runs: place their events at the first stamp seen.
        if not self._events or self.newest_stamp_ns <= 0:
            return
        stamps = np.array([s if s > 0 else self.newest_stamp_ns for s, _, _ in self._events],
                          dtype='datetime64[ns]')
        self.recording.send_columns(
            EVENTS, indexes=[rr.TimeColumn(TIMELINE, timestamp=stamps)],
            columns=rr.TextLog.columns(text=[text for _, text, _ in self._events],
                                       level=[level for _, _, level in self._events]))
        self.counts.events_logged += len(self._events)
        self._events = []

    def _flush_sun(self):
        suns, self._suns = self._suns, []
        centre = self.positions_enu.mean(axis=0)
        for stamp_ns, vector in suns:
            if stamp_ns == self._sun_logged_ns:
                continue
            self._at(stamp_ns)
            if vector[2] <= 0.0:
                self.recording.log(SUN, rr.Clear(recursive=False))
            else:
                self.recording.log(SUN, rr.Arrows3D(
                    origins=[centre + SUN_ARROW_M * vector], vectors=[-SUN_ARROW_M * vector],
                    colors=[(255, 196, 0)], labels=['sun']))
            self._sun_logged_ns = stamp_ns

    def _at(self, stamp_ns):
        self.recording.set_time(TIMELINE, timestamp=np.datetime64(int(stamp_ns), 'ns'))


# -- topics -> scene ---------------------------------------------------------------------------

def scene_topics(facade=None):
    """Return the contract :class:`~flectofold_ros.wire.contract.Topic` s a scene shows.

    The facade-level ``panel_states`` (every panel of a process in one message) and the sun;
    not the per-panel topics, which are published only on change. ``facade`` is accepted for
    callers that name it; the topics do not depend on it.
    """
    return [contract.PANEL_STATES, contract.SUN]


def stamp_ns(header):
    """Nanoseconds of a ``std_msgs/Header`` stamp."""
    return header.stamp.sec * 10**9 + header.stamp.nanosec


def feed(scene, topic, message, received_ns=None):
    """Hand one message of a :func:`scene_topics` topic to ``scene``.

    ``message`` may be an rclpy message or a rosbags one: both have the same fields. Both
    topics are stamped, so ``received_ns`` (the ROS time it arrived) is not needed; it is kept
    in the signature for the callers. A ``panel_states`` message whose layout is not the
    contract's counts as one rejected.
    """
    if topic == contract.PANEL_STATES.name:
        try:
            table = panel_states.unpack(message)
        except ValueError:
            scene.counts.rejected += 1
            return
        scene.panel_states(stamp_ns(message.header), table)
    elif topic == contract.SUN.name:
        v = message.vector
        scene.sun(stamp_ns(message.header), (v.x, v.y, v.z))
