"""The facade in Rerun: folded panel meshes, sun, surface, time series and status, on ROS time.

No rclpy here. The live ``rerun_bridge`` node and the offline bag converter (``replay
--to-rrd``) feed the same :class:`FacadeScene` with plain values, so a bag converted later
gives the recording the live bridge gave.

Entity layout (timeline ``ros_time``, a timestamp from the message stamps; world frame = the
site's ENU frame, z up, REP-103):

- ``/facade/surface``: the facade surface, one facet per patch (static).
- ``/facade/panels/<id>``: the panel's pose on the facade (static ``Transform3D``).
- ``/facade/panels/<id>/mesh``: the folded panel from ``flectofold_model`` with vertex normals.
  Faces are static; vertex positions and normals are logged when the fold angle changes by
  more than ``min_change_rad``; the colour (albedo) when the panel's colour changes: closure or
  gauge pressure on a light-to-dark ramp, red while the panel reports a fault.
- ``/sun``: an arrow from the sun toward the facade (cleared below the horizon).
- ``/metrics/pressure_gauge_pa/<id>``, ``/metrics/fold_angle_rad/<id>``,
  ``/metrics/closure/<id>``: time series.
- ``/facade/events``: text log of every panel status and fault change.

Inputs are checked: an unknown panel id or a non-finite value is counted in ``rejected`` and
not logged, so a bad message never corrupts the recording.
"""

from dataclasses import dataclass
import math

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from flectofold_model.actuation import ATMOSPHERIC_PRESSURE_PA
from flectofold_model.kinematics.closure import FoldModel
from flectofold_model.kinematics.mesh import fold_mesh
from flectofold_model.kinematics.panel import PanelBatch
from flectofold_ros import contract

TIMELINE = 'ros_time'
COLOR_MODES = ('closure', 'pressure')
#: Gauge pressure at the dark end of the pressure colour ramp [Pa].
PRESSURE_FULL_SCALE_PA = 12e3
FAULT_RGBA = (215, 38, 38, 255)
#: Open (0) to closed (1): sand to deep blue-green.
_RAMP = np.array([[236, 226, 198], [122, 170, 160], [24, 78, 104]], dtype=float)
_SURFACE_RGBA = (150, 150, 150, 90)
SUN_ARROW_M = 3.0
SERIES = ('pressure_gauge_pa', 'fold_angle_rad', 'closure')


@dataclass
class SceneCounts:
    """What a scene has logged so far."""

    meshes_logged: int = 0
    meshes_unchanged: int = 0
    """Panel updates not re-meshed because the fold angle moved less than the threshold."""
    colours_logged: int = 0
    samples_logged: int = 0
    events_logged: int = 0
    rejected: int = 0
    """Unknown panel ids and non-finite values, dropped."""


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
                    rrb.TimeSeriesView(origin='/metrics/pressure_gauge_pa',
                                       name='Cushion pressure [Pa gauge]', axis_x=whole),
                    rrb.TimeSeriesView(origin='/metrics/closure', name='Closure [-]',
                                       axis_x=whole),
                ),
                rrb.TimeSeriesView(origin='/metrics/fold_angle_rad', name='Fold angle [rad]',
                                   axis_x=whole),
                rrb.TextLogView(origin='/facade/events', name='Faults and status'),
                row_shares=[2, 2, 1]),
            column_shares=[3, 2]),
        collapse_panels=True)


def ramp_colour(fraction):
    """RGBA (uint8) of a fraction in [0, 1] on the open-to-closed ramp (clipped)."""
    fraction = float(np.clip(fraction, 0.0, 1.0)) * (len(_RAMP) - 1)
    low = min(int(fraction), len(_RAMP) - 2)
    rgb = _RAMP[low] + (fraction - low) * (_RAMP[low + 1] - _RAMP[low])
    return tuple(int(round(c)) for c in rgb) + (255,)


class FacadeScene:
    """Logs one facade to a Rerun recording; feed it messages, call :meth:`flush` often.

    ``recording`` is an ``rr.RecordingStream`` with its sinks set. Updates are collected per
    panel and written by :meth:`flush`, which logs only panels whose fold angle or colour
    changed: at any message rate the work per flush is bounded by the panel count.
    With ``every_state`` (offline conversion, where time is no object) a fold angle that
    would replace one not yet logged flushes first, so no state is merged away.
    """

    def __init__(self, facade, recording, color_by='closure', min_change_rad=1e-3,
                 every_state=False):
        if color_by not in COLOR_MODES:
            raise ValueError(f'color_by must be one of {", ".join(COLOR_MODES)}, '
                             f'got {color_by!r}')
        if not (isinstance(min_change_rad, (int, float)) and 0.0 <= min_change_rad < 0.1):
            raise ValueError(f'min_change_rad must lie in [0, 0.1), got {min_change_rad!r}')
        self.facade, self.recording = facade, recording
        self.color_by, self.min_change_rad = color_by, float(min_change_rad)
        self.every_state = every_state
        self.index = {panel_id: i for i, panel_id in enumerate(facade.panel_ids)}
        self.model = FoldModel(PanelBatch.from_panels(facade.panels))
        self.positions_enu = facade.origin_m @ facade.facade_to_enu.T
        """(N, 3) panel origins in the site ENU frame [m]."""
        count = len(facade)
        self.angle_limits_rad = (self.model.fold_angle_from_closure(np.zeros(count)),
                                 self.model.fold_angle_from_closure(np.ones(count)))
        self.fold_angle_rad = self.angle_limits_rad[0].copy()
        self.stamp_ns = np.zeros(count, dtype=np.int64)
        self.touched_ns = np.zeros(count, dtype=np.int64)
        """Stamp of each panel's newest input: when its colour changes [ns]."""
        self.logged_angle_rad = np.full(count, np.nan)
        self.gauge_pa = np.zeros(count)
        self.closure = np.zeros(count)
        self.fault = [''] * count
        self.logged_colour = [None] * count
        self._dirty = set()
        self._series = {name: [[] for _ in range(count)] for name in SERIES}
        self._events = []
        self._sun = None
        self._sun_logged_ns = None
        self.counts = SceneCounts()
        self.newest_stamp_ns = 0

    # -- static content ---------------------------------------------------------------------

    def log_static(self):
        """Log the frame convention, the surface, the panel poses and the mesh faces."""
        rec = self.recording
        rec.log('/', rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        positions = self.positions_enu
        rotations = self.facade.panel_to_enu
        faces = fold_mesh(self.model.batch, np.zeros(len(self.facade))).faces.astype(np.uint32)
        for panel_id, i in self.index.items():
            rec.log(f'/facade/panels/{panel_id}',
                    rr.Transform3D(translation=positions[i], mat3x3=rotations[i]), static=True)
            rec.log(f'/facade/panels/{panel_id}/mesh',
                    rr.Mesh3D.from_fields(triangle_indices=faces), static=True)
            for name in SERIES:
                rec.log(f'/metrics/{name}/{panel_id}', rr.SeriesLines(names=panel_id),
                        static=True)
        vertices, triangles = self.surface_facets()
        rec.log('/facade/surface', rr.Mesh3D(vertex_positions=vertices,
                                             triangle_indices=triangles,
                                             albedo_factor=_SURFACE_RGBA), static=True)

    def surface_facets(self, depth_m=0.05):
        """One quad per patch, ``depth_m`` behind the panels: (4N, 3) vertices, (2N, 3) faces."""
        batch = self.model.batch
        half_x, half_y = batch.length_m / 2, batch.width_m / 2
        corners = np.stack([np.stack([sx * half_x, sy * half_y, np.full_like(half_x, -depth_m)],
                                     axis=-1)
                            for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))], axis=1)
        world = np.einsum('nij,nkj->nki', self.facade.panel_to_enu, corners) \
            + self.positions_enu[:, None, :]
        base = 4 * np.arange(len(batch))[:, None]
        triangles = np.concatenate([base + [0, 1, 2], base + [0, 2, 3]]).astype(np.uint32)
        return world.reshape(-1, 3).astype(np.float32), triangles

    # -- inputs -----------------------------------------------------------------------------

    def _panel(self, panel_id, value):
        i = self.index.get(panel_id)
        if i is None or not math.isfinite(value):
            self.counts.rejected += 1
            return None
        return i

    def fold_angle(self, panel_id, stamp_ns, fold_angle_rad):
        """Take a panel's fold angle (``joint_states``) at ``stamp_ns`` [ns of ROS time]."""
        i = self._panel(panel_id, fold_angle_rad)
        if i is not None:
            if self.every_state and i in self._dirty and self.stamp_ns[i] != stamp_ns:
                self.flush()
            self.fold_angle_rad[i], self.stamp_ns[i] = fold_angle_rad, stamp_ns
            self._touch(i, stamp_ns)
            self._sample('fold_angle_rad', i, stamp_ns, fold_angle_rad)

    def pressure(self, panel_id, stamp_ns, pressure_pa):
        """Take a panel's absolute cushion pressure [Pa] (``FluidPressure``)."""
        i = self._panel(panel_id, pressure_pa)
        if i is not None:
            self.gauge_pa[i] = pressure_pa - ATMOSPHERIC_PRESSURE_PA
            self._sample('pressure_gauge_pa', i, stamp_ns, self.gauge_pa[i])
            if self.color_by == 'pressure':
                self._touch(i, stamp_ns)

    def closure_value(self, panel_id, stamp_ns, closure):
        """Take a panel's closure [-] (``closure``; unstamped, so the receive time)."""
        i = self._panel(panel_id, closure)
        if i is not None:
            self.closure[i] = closure
            self._sample('closure', i, stamp_ns, closure)
            if self.color_by == 'closure':
                self._touch(i, stamp_ns)

    def status(self, panel_id, stamp_ns, text, is_fault=False):
        """Take a panel's latched ``status`` or ``fault`` text; faults turn the panel red."""
        i = self.index.get(panel_id)
        if i is None:
            self.counts.rejected += 1
            return
        if is_fault:
            self.fault[i] = '' if text == contract.NO_FAULT else text
            self._touch(i, stamp_ns)
        level = 'ERROR' if is_fault and text != contract.NO_FAULT else 'INFO'
        label = 'fault' if is_fault else 'status'
        self._events.append((stamp_ns, f'{panel_id} {label}: {text}', level))

    def sun(self, stamp_ns, vector_enu):
        """Take the unit vector toward the sun in the site ENU frame."""
        vector = np.asarray(vector_enu, dtype=float)
        if vector.shape != (3,) or not np.all(np.isfinite(vector)):
            self.counts.rejected += 1
            return
        self._sun = (stamp_ns, vector)

    def _touch(self, i, stamp_ns):
        self.touched_ns[i] = max(self.touched_ns[i], stamp_ns)
        self._dirty.add(i)

    def _sample(self, name, i, stamp_ns, value):
        if stamp_ns > 0:  # before the first /clock, a sim-time receiver stamps 0
            self._series[name][i].append((stamp_ns, float(value)))
            self.newest_stamp_ns = max(self.newest_stamp_ns, stamp_ns)

    def _at(self, stamp_ns):
        self.recording.set_time(TIMELINE, timestamp=np.datetime64(int(stamp_ns), 'ns'))

    # -- output -----------------------------------------------------------------------------

    def flush(self):
        """Log what changed since the last flush; return the number of meshes logged."""
        self._flush_series()
        self._flush_sun()
        self._flush_events()
        if not self._dirty or self.newest_stamp_ns <= 0:
            return 0
        dirty = np.array(sorted(self._dirty))
        self._dirty.clear()
        stamped = dirty[self.stamp_ns[dirty] > 0]  # a mesh needs a fold angle and its stamp
        moved = stamped[~(np.abs(self.fold_angle_rad[stamped] - self.logged_angle_rad[stamped])
                          <= self.min_change_rad)]
        self.counts.meshes_unchanged += len(stamped) - len(moved)
        if len(moved):
            self._log_meshes(moved)
        for i in dirty:
            self._log_colour(i)
        return len(moved)

    def _log_meshes(self, panels):
        # The loops interpolate a table, so a reported angle can pass a limit by a rounding.
        closure = self.model.closure_from_fold_angle(np.clip(self.fold_angle_rad,
                                                             *self.angle_limits_rad))
        k = self.model.state_from_closure(closure).elastica_k
        mesh = fold_mesh(self.model.batch.take(panels), k[panels], dtype=np.float32)
        for row, i in enumerate(panels):
            self._at(self.stamp_ns[i])
            self.recording.log(f'/facade/panels/{self.facade.panel_ids[i]}/mesh',
                               rr.Mesh3D.from_fields(vertex_positions=mesh.vertices[row],
                                                     vertex_normals=mesh.normals[row]))
            self.logged_angle_rad[i] = self.fold_angle_rad[i]
        self.counts.meshes_logged += len(panels)

    def panel_colour(self, i):
        """RGBA of panel ``i`` now: red on a fault, else its closure or pressure on the ramp."""
        if self.fault[i]:
            return FAULT_RGBA
        if self.color_by == 'pressure':
            return ramp_colour(self.gauge_pa[i] / PRESSURE_FULL_SCALE_PA)
        return ramp_colour(self.closure[i])

    def _log_colour(self, i):
        colour = self.panel_colour(i)
        if colour == self.logged_colour[i]:
            return
        self._at(self.touched_ns[i] if self.touched_ns[i] > 0 else self.newest_stamp_ns)
        self.recording.log(f'/facade/panels/{self.facade.panel_ids[i]}/mesh',
                           rr.Mesh3D.from_fields(albedo_factor=colour))
        self.logged_colour[i] = colour
        self.counts.colours_logged += 1

    def _flush_series(self):
        for name, per_panel in self._series.items():
            for i, samples in enumerate(per_panel):
                if not samples:
                    continue
                stamps = np.array([s for s, _ in samples], dtype='datetime64[ns]')
                values = np.array([v for _, v in samples])
                self.recording.send_columns(
                    f'/metrics/{name}/{self.facade.panel_ids[i]}',
                    indexes=[rr.TimeColumn(TIMELINE, timestamp=stamps)],
                    columns=rr.Scalars.columns(scalars=values))
                self.counts.samples_logged += len(samples)
                samples.clear()

    def _flush_events(self):
        # Latched texts can arrive before the clock runs: place them at the first stamp seen.
        if self.newest_stamp_ns <= 0:
            return
        for stamp_ns, text, level in self._events:
            self._at(stamp_ns if stamp_ns > 0 else self.newest_stamp_ns)
            self.recording.log('/facade/events', rr.TextLog(text, level=level))
        self.counts.events_logged += len(self._events)
        self._events.clear()

    def _flush_sun(self):
        if self._sun is None or self._sun[0] == self._sun_logged_ns:
            return
        stamp_ns, vector = self._sun
        self._at(stamp_ns)
        if vector[2] <= 0.0:
            self.recording.log('/sun', rr.Clear(recursive=False))
        else:
            centre = self.positions_enu.mean(axis=0)
            self.recording.log('/sun', rr.Arrows3D(
                origins=[centre + SUN_ARROW_M * vector], vectors=[-SUN_ARROW_M * vector],
                colors=[(255, 196, 0)], labels=['sun']))
        self._sun_logged_ns = stamp_ns


# -- topics -> scene ---------------------------------------------------------------------------

#: The panel topics a scene shows.
PANEL_TOPICS = (contract.JOINT_STATES, contract.PRESSURE, contract.CLOSURE, contract.FAULT,
                contract.STATUS)


def scene_topics(facade):
    """Return the contract :class:`~flectofold_ros.contract.Topic` of all a scene shows."""
    return [contract.SUN] + [topic.of(panel_id) for panel_id in facade.panel_ids
                             for topic in PANEL_TOPICS]


def stamp_ns(header):
    """Nanoseconds of a ``std_msgs/Header`` stamp."""
    return header.stamp.sec * 10**9 + header.stamp.nanosec


def feed(scene, topic, message, received_ns):
    """Hand one message of a :func:`scene_topics` topic to ``scene``.

    ``message`` may be an rclpy message or a rosbags one: both have the same fields.
    ``received_ns`` is the ROS time it arrived (used for unstamped messages).
    """
    if topic == contract.SUN.name:
        v = message.vector
        scene.sun(stamp_ns(message.header), (v.x, v.y, v.z))
        return
    panel_id, suffix = topic[len(contract.FACADE_NAMESPACE) + 1:].split('/', 1)
    if suffix == contract.JOINT_STATES.suffix:
        if len(message.position):
            scene.fold_angle(panel_id, stamp_ns(message.header), float(message.position[0]))
        else:
            scene.counts.rejected += 1
    elif suffix == contract.PRESSURE.suffix:
        scene.pressure(panel_id, stamp_ns(message.header), float(message.fluid_pressure))
    elif suffix == contract.CLOSURE.suffix:
        scene.closure_value(panel_id, received_ns, float(message.data))
    elif suffix in (contract.FAULT.suffix, contract.STATUS.suffix):
        scene.status(panel_id, received_ns, str(message.data),
                     is_fault=suffix == contract.FAULT.suffix)
