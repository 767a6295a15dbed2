"""Annual daylight of the shoebox office behind a Flectofold facade, by daylight coefficients.

The office :class:`~flectofold_model.building.energyplus_model.Room` and the facade's folded
panels become a Radiance scene (:func:`radiance_scene`); ``rcontrib`` gives, per closure state,
the daylight coefficients from the 145 patches of a Reinhart MF:1 sky plus the ground to a
work-plane grid of sensors (:func:`daylight_coefficients`); ``gendaymtx`` gives one sky vector
per hour of a weather file, and the illuminance of a sensor is ``179 W/lm * (0.265 R + 0.670 G
+ 0.065 B)`` of the coefficients times the sky (:func:`annual_illuminance`), with the
coefficients of the closure the facade holds that hour, interpolated linearly between the two
nearest computed states. :func:`spatial_daylight_autonomy` and :func:`useful_daylight` reduce
the result to sDA300/50% and UDI 100-2000 lx; :func:`annual_sunlight_exposure` to ASE1000,250h.

Frames
------
- **Facade frame** (of ``facade_export --surface-quads`` and
  :attr:`~flectofold_model.facade.description.Facade.origin_m`): x along the facade (to the
  right seen from outside), y up, z out of the building, origin at the facade surface's
  centre. A facade's site-frame meshes (:func:`~flectofold_model.facade.folded_mesh.
  folded_meshes`: x east, y north, z up) map onto it as ``p_facade = R.T @ p_site`` with ``R =
  facade.facade_to_enu`` (:func:`facade_triangles`).
- **Room frame**: origin at the inside face of the window wall, at floor level, at the middle
  of the wall; x along the facade (as in the facade frame), y into the room (``-z`` of the
  facade frame), z up. The room spans ``-width/2 <= x <= width/2``, ``0 <= y <= depth``,
  ``0 <= z <= height``; the wall's exterior face is at ``y = -wall_thickness``.
- **Scene frame** (Radiance's world: +Y north, +X east, +Z up, as ``gendaymtx``,
  ``gendaylit`` and ``reinhartb.cal`` assume): the room frame turned about z by
  ``180 - azimuth`` degrees (:func:`room_to_scene`). For a facade facing south it *is* the
  room frame, and generally it is the site frame (east, north, up) moved to the room's origin.
- A facade-frame point ``(u, v, w)`` is placed at room-frame ``(u, -(w - w_min) -
  wall_thickness - gap, v + facade_centre_height)``: the facade's centre at
  ``facade_centre_height`` (default mid-height of the wall), its back-most point ``w_min``
  ``gap`` (0.05 m) in front of the wall's exterior face.

Radiance facts used (Radiance 6 reference manual and man pages: ``rcontrib(1)``,
``gendaymtx(1)``, ``gendaylit(1)``, ``rtrace(1)``): a ``glass`` material's transmissivity is
``tn = 1.0895 Tvis`` for normal-incidence visible transmittance ``Tvis`` of a single pane
(the manual's approximation); ``reinhartb.cal`` numbers the MF:1 patches 0-144 (Reinhart's
subdivision of the Tregenza sky, 145 patches at MF:1; 144 MF^2 + 1 in general), the ground
is a separate hemisphere put first, as ``gendaymtx``'s first row is the ground; ``rcontrib
-I+`` gives irradiance per unit radiance of each bin; ``gendaymtx -O0`` gives visible radiance
in W/(sr m2) that 179 lm/W turns into luminance.

Metrics: sDA300/50% and ASE1000,250h after IES LM-83-12 ("Approved method: IES spatial
daylight autonomy (sDA) and annual sunlight exposure (ASE)"), hours 08:00-18:00 local standard
time (3650 a year); UDI after Nabil & Mardaljevic, Lighting Res. Technol. 37 (2005) 41-59.
"""

import dataclasses
from dataclasses import dataclass
import hashlib
import math
import os
import subprocess
import tempfile
import time
from typing import Any, Callable, cast, Mapping, Optional, Sequence, TYPE_CHECKING, Union

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import BoolArray, FloatArray, PathLike

if TYPE_CHECKING:  # the facade's and the room's modules load when used
    from flectofold_model.building.energyplus_model import Room
    from flectofold_model.facade.description import Facade

#: Radiance ``glass`` transmissivity per unit visible transmittance (Radiance manual).
GLASS_TN_PER_TVIS = 1.0895
#: Luminous efficacy Radiance uses for its visible radiometric units [lm/W].
LUMINOUS_EFFICACY = 179.0
#: Weights of R, G and B for luminance in Radiance's RGB primaries.
RGB_WEIGHTS = np.array([0.265, 0.670, 0.065])
#: Patches of each Reinhart sky (``MF:n``) with the ground: 1 + 144 n^2 + 1.
SKY_PATCHES = {'r1': 146, 'r2': 578, 'r4': 2306, 'r6': 5186}
#: Grey reflectances of the surfaces [-].
REFLECTANCES = {'floor': 0.2, 'walls': 0.5, 'ceiling': 0.7, 'exterior': 0.35, 'panels': 0.35}
#: ``rcontrib`` parameters of the annual matrices: 5 ambient bounces, 10,000 divisions and
#: a weight limit of 1e-6 (1e-4 cut the interreflections deep in the room: 5-29 % below the
#: converged value on an overcast hour), no ambient cache (``rcontrib`` cannot use one).
MATRIX_PARAMS = ('-ab', '5', '-ad', '10000', '-lw', '1e-6')
#: Office hours, local standard time, hour starting at 8 and ending at 18 [h].
OFFICE_HOURS = (8.0, 18.0)


def _radiance() -> Mapping[str, str]:
    """Import pyradiance, which puts its Radiance binaries on PATH and sets RAYPATH."""
    import pyradiance  # noqa: F401
    return os.environ


def room_to_scene(room: 'Room') -> FloatArray:
    """Rotation (3, 3) from the room frame to the scene frame (east, north, up)."""
    angle = math.radians(180.0 - room.azimuth_deg)
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def facade_triangles(facade: 'Facade', closure: npt.ArrayLike, room: Optional['Room'] = None,
                     margin_m: float = 1.0) -> FloatArray:
    """Triangles (T, 3, 3) of ``facade`` at one closure, in its facade frame [m].

    Every panel's folded mesh (:func:`~flectofold_model.facade.folded_mesh.folded_meshes`,
    site frame) taken to the facade frame with ``p = facade.facade_to_enu.T @ p_site``. If
    the facade is narrower than the room's wall plus ``margin_m`` on either side, it is
    repeated side by side at its own width (the panel pitch times the columns), as the same
    facade on the neighbouring offices would be; then only panels whose centre lies within
    the wall's width plus the margin and half a panel pitch on either side are kept.
    """
    from flectofold_model.building.energyplus_model import Room
    from flectofold_model.facade.folded_mesh import folded_meshes
    room = Room() if room is None else room
    meshes = folded_meshes(facade, closure=closure, weld_vertices=False)
    to_facade = np.asarray(facade.facade_to_enu).T
    panels = [mesh.vertices_m[mesh.faces] @ to_facade.T for mesh in meshes]
    origins = np.asarray(facade.origin_m)
    columns = np.unique(np.round(origins[:, 0], 6))
    pitch = float(np.median(np.diff(columns))) if len(columns) > 1 else 0.0
    period = pitch * len(columns)
    reach = room.width_m / 2.0 + margin_m + pitch / 2.0
    missing = max(0.0, reach - columns.max() - pitch / 2.0)
    copies = int(math.ceil(missing / period)) if period else 0
    kept = []
    for shift in range(-copies, copies + 1):
        offset = np.array([shift * period, 0.0, 0.0])
        for origin, triangles in zip(origins, panels):
            if abs(origin[0] + offset[0]) <= reach:
                kept.append(triangles + offset)
    return np.concatenate(kept)


def radiance_scene(room: 'Room', panel_triangles: Optional[npt.ArrayLike], gap_m: float = 0.05,
                   wall_thickness_m: float = 0.2, facade_centre_height_m: Optional[float] = None,
                   margin_m: float = 1.0,
                   reflectances: Optional[Mapping[str, float]] = None) -> str:
    """Radiance scene text (materials and polygons) of the room and its facade, scene frame.

    Parameters
    ----------
    room : Room
        The office: size, centred window (``window_width_m`` by ``window_height_m``), visible
        transmittance ``glazing_vt`` and facade azimuth.
    panel_triangles : array-like (T, 3, 3) or None
        The facade's triangles in its facade frame (:func:`facade_triangles`), placed as the
        module docstring says; ``None`` for the bare window.
    gap_m : float
        Clearance between the back-most point of the panels and the wall's exterior face [m].
    wall_thickness_m : float
        Thickness of the window wall; the glass sits in its middle, with reveals [m].
    facade_centre_height_m : float, optional
        Height of the facade frame's origin above the floor; default half the room height.
    margin_m : float
        How far the wall's exterior face extends beyond the room on either side and above and
        below, so that no light passes behind the panels beside the room [m].
    reflectances : dict, optional
        Overrides of :data:`REFLECTANCES` (``floor``, ``walls``, ``ceiling``, ``exterior``
        for the wall's outside and reveals, ``panels`` for the GFRP panels).

    Returns
    -------
    str
        ``plastic`` materials ``floor``, ``walls``, ``ceiling``, ``exterior``, ``panels``, the
        ``glass`` material ``window`` (``tn = 1.0895 VT``) and polygons facing into the room
        (interior) or out (exterior). No sky: :func:`daylight_coefficients` and
        :func:`point_illuminance` add their own.
    """
    rho = dict(REFLECTANCES, **(reflectances or {}))
    w, d, h = room.width_m, room.depth_m, room.height_m
    ww, wh = room.window_width_m, room.window_height_m
    x0, x1, z0 = -ww / 2.0, ww / 2.0, (h - wh) / 2.0
    z1, t, m = z0 + wh, wall_thickness_m, margin_m
    rotation = room_to_scene(room)
    lines = [f'# flectofold daylight scene: room {w:g} x {d:g} x {h:g} m, window {ww:.3f} x '
             f'{wh:.3f} m, VT {room.glazing_vt:g}, azimuth {room.azimuth_deg:g} deg']
    for name in ('floor', 'walls', 'ceiling', 'exterior', 'panels'):
        r = rho[name]
        lines.append(f'void plastic {name} 0 0 5 {r:g} {r:g} {r:g} 0 0')
    tn = GLASS_TN_PER_TVIS * room.glazing_vt
    lines.append(f'void glass window 0 0 3 {tn:.5f} {tn:.5f} {tn:.5f}')
    count = [0]

    def polygon(material: str, points: npt.ArrayLike) -> None:
        points = np.asarray(points, dtype=float) @ rotation.T
        count[0] += 1
        coordinates = ' '.join(f'{value:.6f}' for value in points.ravel())
        lines.append(f'{material} polygon {material}.{count[0]} 0 0 {3 * len(points)} '
                     f'{coordinates}')

    def rectangle(material: str, corner: Sequence[float], edge_a: Sequence[float],
                  edge_b: Sequence[float]) -> None:
        """Rectangle from ``corner`` along ``edge_a`` then ``edge_b``: normal a x b."""
        corner, edge_a, edge_b = (np.asarray(v, dtype=float) for v in (corner, edge_a, edge_b))
        polygon(material, [corner, corner + edge_a, corner + edge_a + edge_b, corner + edge_b])

    def framed(material: str, y: float, xa: float, xb: float, za: float, zb: float,
               inward: bool) -> None:
        """Four rectangles of the plane at ``y`` from x xa..xb, z za..zb less the window."""
        for (ua, ub, va, vb) in ((xa, xb, za, z0), (xa, xb, z1, zb), (xa, x0, z0, z1),
                                 (x1, xb, z0, z1)):
            if inward:  # normal +y
                rectangle(material, (ua, y, va), (0, 0, vb - va), (ub - ua, 0, 0))
            else:
                rectangle(material, (ua, y, va), (ub - ua, 0, 0), (0, 0, vb - va))

    # Interior, normals into the room.
    rectangle('floor', (-w / 2, 0, 0), (w, 0, 0), (0, d, 0))
    rectangle('ceiling', (-w / 2, 0, h), (0, d, 0), (w, 0, 0))
    rectangle('walls', (-w / 2, d, 0), (w, 0, 0), (0, 0, h))
    rectangle('walls', (-w / 2, 0, 0), (0, d, 0), (0, 0, h))
    rectangle('walls', (w / 2, 0, 0), (0, 0, h), (0, d, 0))
    framed('walls', 0.0, -w / 2, w / 2, 0.0, h, inward=True)
    # Reveals from the inside face to the exterior face, normals into the opening.
    rectangle('exterior', (x0, -t, z0), (0, t, 0), (x1 - x0, 0, 0))
    rectangle('exterior', (x0, -t, z1), (x1 - x0, 0, 0), (0, t, 0))
    rectangle('exterior', (x0, -t, z0), (0, 0, wh), (0, t, 0))
    rectangle('exterior', (x1, -t, z0), (0, t, 0), (0, 0, wh))
    # Glass mid-wall, normal into the room; exterior face with the margin, normal out.
    rectangle('window', (x0, -t / 2, z0), (0, 0, wh), (x1 - x0, 0, 0))
    framed('exterior', -t, -w / 2 - m, w / 2 + m, -m, h + m, inward=False)
    if panel_triangles is not None:
        tri = np.array(panel_triangles, dtype=float).reshape(-1, 3, 3)
        centre = h / 2.0 if facade_centre_height_m is None else facade_centre_height_m
        back = tri[..., 2].min()
        placed = np.stack([tri[..., 0], -(tri[..., 2] - back) - t - gap_m,
                           tri[..., 1] + centre], axis=-1)
        for triangle in placed:
            polygon('panels', triangle)
    return '\n'.join(lines) + '\n'


def grid_axes(room: 'Room', spacing_m: float = 0.6,
              wall_offset_m: float = 0.5) -> tuple[FloatArray, FloatArray]:
    """Positions across (x, centred) and into the room (y) of the work-plane grid [m].

    ``wall_offset_m`` from every wall, the fewest points per row and column whose spacing
    is at most ``spacing_m`` (LM-83-12: at most 2 ft, 0.61 m).
    """
    def axis(length: float) -> FloatArray:
        span = length - 2.0 * wall_offset_m
        if span <= 0.0:
            raise ValueError(f'the room ({length:g} m) leaves no grid {wall_offset_m:g} m '
                             'from its walls')
        count = int(math.ceil(span / spacing_m - 1e-9)) + 1
        return np.linspace(wall_offset_m, length - wall_offset_m, count)

    return axis(room.width_m) - room.width_m / 2.0, axis(room.depth_m)


def sensor_grid(room: 'Room', spacing_m: float = 0.6, height_m: float = 0.76,
                wall_offset_m: float = 0.5) -> FloatArray:
    """Work-plane sensors (N, 6): positions and upward directions in the scene frame.

    The grid of :func:`grid_axes` at ``height_m`` (LM-83-12: 30 in, 0.76 m), ordered by
    depth (rows from the window back), then across.
    """
    across, depth = grid_axes(room, spacing_m, wall_offset_m)
    yy, xx = np.meshgrid(depth, across, indexing='ij')
    points = np.stack([xx.ravel(), yy.ravel(), np.full(xx.size, height_m)], axis=-1)
    points = points @ room_to_scene(room).T
    return np.concatenate([points, np.tile([0.0, 0.0, 1.0], (len(points), 1))], axis=1)


def _octree(scene: str, folder: str, sky_text: str) -> str:
    """Write ``scene`` plus ``sky_text`` and compile them with ``oconv``; return the path."""
    environment = _radiance()
    path = os.path.join(folder, 'scene.rad')
    with open(path, 'w') as stream:
        stream.write(sky_text + scene)
    octree = os.path.join(folder, 'scene.oct')
    with open(octree, 'wb') as stream:
        subprocess.run(['oconv', path], stdout=stream, check=True, env=environment)
    return octree


def _rays(sensors: npt.ArrayLike) -> str:
    return ''.join(' '.join(f'{v:.6f}' for v in row) + '\n'
                   for row in np.asarray(sensors, dtype=float).reshape(-1, 6))


@dataclass(frozen=True)
class DaylightCoefficients:
    """Daylight coefficients of one scene: irradiance per unit sky-patch radiance."""

    values: np.ndarray
    """(N sensors, P patches, 3 RGB): ground first, then the Reinhart patches [sr]."""
    elapsed_s: float
    """Wall-clock time of the ``rcontrib`` run [s]."""
    params: tuple
    """The ``rcontrib`` ray parameters used."""


_CACHE: dict[str, Any] = {}


def daylight_coefficients(scene: str, sensors: npt.ArrayLike, sky: str = 'r1',
                          params: Sequence[str] = MATRIX_PARAMS,
                          processes: int = 2) -> DaylightCoefficients:
    """Daylight coefficients (:class:`DaylightCoefficients`) of ``scene`` at ``sensors``.

    ``rcontrib -I+ -faf -b 0 -bn 1 -m groundglow -f reinhartb.cal -p MF=n -b rbin -bn
    Nrbins -m skyglow`` on the octree of the scene and two ``glow`` hemispheres of unit
    radiance, ground (one bin, first) and sky (the Reinhart patches), ``params`` (default
    :data:`MATRIX_PARAMS`) and ``processes`` workers. One scene per closure state; results
    are cached in memory by the scene text, the sensors, the sky and the parameters, so a
    state is traced once per process.
    """
    if sky not in SKY_PATCHES:
        raise ValueError(f'sky must be one of {sorted(SKY_PATCHES)}, got {sky!r}')
    sensors = np.asarray(sensors, dtype=float).reshape(-1, 6)
    key = hashlib.sha256('\0'.join([scene, sensors.tobytes().hex(), sky, ' '.join(params),
                                    str(processes)]).encode()).hexdigest()
    if key in _CACHE:
        return _CACHE[key]
    environment = _radiance()
    sky_text = ('void glow groundglow 0 0 4 1 1 1 0\n'
                'groundglow source ground 0 0 4 0 0 -1 180\n'
                'void glow skyglow 0 0 4 1 1 1 0\n'
                'skyglow source skydome 0 0 4 0 0 1 180\n')
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix='flectofold_dc_') as folder:
        octree = _octree(scene, folder, sky_text)
        command = ['rcontrib', '-h', '-I+', '-faf', '-n', str(processes), *params,
                   '-b', '0', '-bn', '1', '-m', 'groundglow', '-f', 'reinhartb.cal',
                   '-p', f'MF={sky[1:]}', '-b', 'rbin', '-bn', 'Nrbins', '-m', 'skyglow', octree]
        result = subprocess.run(command, input=_rays(sensors).encode(), capture_output=True,
                                check=True, env=environment)
    values = np.frombuffer(result.stdout, dtype=np.float32).astype(float)
    patches = SKY_PATCHES[sky]
    if values.size != len(sensors) * patches * 3:
        raise RuntimeError(f'rcontrib gave {values.size} values, expected '
                           f'{len(sensors) * patches * 3}: {result.stderr.decode()[-500:]}')
    coefficients = DaylightCoefficients(values.reshape(len(sensors), patches, 3),
                                        time.perf_counter() - started, tuple(params))
    _CACHE[key] = coefficients
    return coefficients


#: Angular diameter of the sun's disc as a Radiance ``source`` [deg] (gendaylit's).
SUN_DIAMETER_DEG = 0.533
#: Solid angle of that disc, ``2 pi (1 - cos(d / 2))`` [sr], the ``source``'s own.
SUN_SOLID_ANGLE_SR = 2.0 * math.pi * (1.0 - math.cos(math.radians(SUN_DIAMETER_DEG / 2.0)))
#: ``rcontrib`` parameters of the sun matrix: direct light only, every source tested, no
#: jitter or sub-sampling (exact shadows of the panels and transmission of the glass).
SUN_PARAMS = ('-ab', '0', '-dc', '1', '-dt', '0', '-dj', '0', '-ds', '0', '-dr', '0')
#: Rows of the Tregenza sky (Reinhart MF:1): patches per 12-degree altitude band, the
#: zenith cap above 84 degrees last (``reinhartb.cal``).
TREGENZA_ROWS = (30, 30, 24, 24, 18, 12, 6)


def tregenza_solid_angles() -> FloatArray:
    """Solid angles (146,) of the ground hemisphere and the 145 Tregenza patches [sr]."""
    angles = [2.0 * math.pi]
    for row, count in enumerate(TREGENZA_ROWS):
        low, high = math.radians(12.0 * row), math.radians(12.0 * (row + 1))
        angles += [2.0 * math.pi * (math.sin(high) - math.sin(low)) / count] * count
    angles.append(2.0 * math.pi * (1.0 - math.sin(math.radians(84.0))))
    return np.array(angles)


@dataclass(frozen=True)
class SkyYear:
    """What a weather file gives the daylight run: site, hours, sky vectors and the sun."""

    latitude_deg: float
    longitude_deg: float
    """East positive."""
    utc_offset_h: float
    month: np.ndarray
    day: np.ndarray
    hour: np.ndarray
    """Mid-hour local standard time of each record, 0.5 ... 23.5 [h]."""
    dni_w_m2: np.ndarray
    dhi_w_m2: np.ndarray
    sky: np.ndarray
    """(146, H, 3): visible radiance of the sky and sun per patch, ground first (the sun
    spread over the patches around it by ``gendaymtx``) [W/(sr m2)]."""
    sun: np.ndarray
    """(146, H, 3): the same of the sun alone (``gendaymtx -d``) [W/(sr m2)]."""
    sun_illuminance_lx: np.ndarray
    """(H,) direct normal illuminance of the sun, ``179 sum_p L_p omega_p`` of :attr:`sun`
    (luminous by :data:`RGB_WEIGHTS`) [lx]."""
    sun_enu: np.ndarray
    """(H, 3) unit vector toward the sun at the record's middle (the project's SPA) [-]."""

    @property
    def office(self) -> BoolArray:
        """Mask (H,) of the office hours, 08:00-18:00 local standard time."""
        return (self.hour >= OFFICE_HOURS[0]) & (self.hour < OFFICE_HOURS[1])

    def epoch_s(self) -> FloatArray:
        """(H,) UTC Unix time of each record's middle, in the project's reference year [s]."""
        from flectofold_model.environment.weather import REFERENCE_YEAR
        dates = np.array([f'{REFERENCE_YEAR}-{m:02d}-{d:02d}' for m, d in
                          zip(self.month, self.day)], dtype='datetime64[s]')
        return dates.astype(np.int64) + (self.hour - self.utc_offset_h) * 3600.0


_WEATHER: dict[str, SkyYear] = {}


def read_skies(epw: PathLike) -> SkyYear:
    """Sky and sun (:class:`SkyYear`) of every hour of ``epw``, cached per file.

    ``epw2wea``, then ``gendaymtx -m 1 -O0`` (visible radiance of the Perez sky of each
    hour's direct and diffuse irradiance, the sun put in the patches around it, ground
    reflectance 0.2) and the same with ``-d`` (the sun alone); the sun's direction by the
    project's SPA (:func:`~flectofold_model.environment.sun.sun_vector_enu`) at the mid-hour
    standard time ``gendaymtx`` uses.
    """
    from flectofold_model.environment.sun import Site, sun_vector_enu
    key = os.path.abspath(epw)
    if key in _WEATHER:
        return _WEATHER[key]
    environment = _radiance()
    with tempfile.TemporaryDirectory(prefix='flectofold_wea_') as folder:
        wea = os.path.join(folder, 'weather.wea')
        subprocess.run(['epw2wea', str(epw), wea], check=True, capture_output=True,
                       env=environment)
        with open(wea) as stream:
            text = stream.read()
        matrices = [_sky_matrix(wea, options, environment) for options in ((), ('-d',))]
    head = dict(line.split(' ', 1) for line in text.splitlines()[:6])
    records = np.array([line.split() for line in text.splitlines()[6:] if line.strip()],
                       dtype=float)
    sun = matrices[1]
    luminous = sun @ RGB_WEIGHTS
    site = Site(float(head['latitude']), -float(head['longitude']),
                float(head.get('site_elevation', 0.0)))
    weather = SkyYear(latitude_deg=site.latitude_deg, longitude_deg=site.longitude_deg,
                      utc_offset_h=-float(head['time_zone']) / 15.0,
                      month=records[:, 0].astype(int), day=records[:, 1].astype(int),
                      hour=records[:, 2], dni_w_m2=records[:, 3], dhi_w_m2=records[:, 4],
                      sky=matrices[0], sun=sun,
                      sun_illuminance_lx=LUMINOUS_EFFICACY * tregenza_solid_angles()
                      @ luminous, sun_enu=np.zeros((len(records), 3)))
    enu = sun_vector_enu(weather.epoch_s(), site)
    weather = dataclasses.replace(weather, sun_enu=np.asarray(enu, dtype=float))
    _WEATHER[key] = weather
    return weather


def _sky_matrix(wea: str, options: Sequence[str], environment: Mapping[str, str]) -> FloatArray:
    result = subprocess.run(['gendaymtx', '-m', '1', '-O0', '-of', *options, wea],
                            capture_output=True, check=True, env=environment)
    header, _, data = result.stdout.partition(b'\n\n')
    fields = dict(line.split('=', 1) for line in header.decode(errors='replace').splitlines()
                  if '=' in line)
    rows, columns = int(fields['NROWS']), int(fields['NCOLS'])
    values = np.frombuffer(data[:rows * columns * 12], dtype=np.float32).astype(float)
    return values.reshape(rows, columns, 3)


def sun_coefficients(scene: str, sensors: npt.ArrayLike, directions: npt.ArrayLike,
                     processes: int = 2) -> FloatArray:
    """Direct sun factor (N, D) of each sensor for suns in ``directions`` (D, 3) [-].

    One Radiance ``light`` source of :data:`SUN_DIAMETER_DEG` and unit radiance per
    direction (scene frame), ``rcontrib`` with :data:`SUN_PARAMS` (direct light only): the
    irradiance per unit radiance, divided by :data:`SUN_SOLID_ANGLE_SR`, is the cosine of
    incidence times the transmittance of whatever lies between (glass, panels, reveals), so
    that the sun's illuminance at a sensor is this factor times the direct normal
    illuminance. Cached in memory like :func:`daylight_coefficients`.
    """
    sensors = np.asarray(sensors, dtype=float).reshape(-1, 6)
    directions = np.asarray(directions, dtype=float).reshape(-1, 3)
    if not len(directions):
        return np.zeros((len(sensors), 0))
    key = hashlib.sha256('\0'.join(['sun', scene, sensors.tobytes().hex(),
                                    directions.tobytes().hex()]).encode()).hexdigest()
    if key in _CACHE:
        return _CACHE[key]
    environment = _radiance()
    suns = ''.join(f'void light sun_{k} 0 0 3 1 1 1\nsun_{k} source sun_{k}.disc 0 0 4 '
                   f'{x:.7f} {y:.7f} {z:.7f} {SUN_DIAMETER_DEG}\n'
                   for k, (x, y, z) in enumerate(directions))
    with tempfile.TemporaryDirectory(prefix='flectofold_sun_') as folder:
        octree = _octree(scene, folder, suns)
        modifiers = os.path.join(folder, 'suns.txt')
        with open(modifiers, 'w') as stream:
            stream.write(''.join(f'sun_{k}\n' for k in range(len(directions))))
        result = subprocess.run(['rcontrib', '-h', '-I+', '-faf', '-n', str(processes),
                                 *SUN_PARAMS, '-M', modifiers, octree],
                                input=_rays(sensors).encode(), capture_output=True,
                                check=True, env=environment)
    values = np.frombuffer(result.stdout, dtype=np.float32).astype(float)
    if values.size != len(sensors) * len(directions) * 3:
        raise RuntimeError(f'rcontrib gave {values.size} values, expected '
                           f'{len(sensors) * len(directions) * 3}: '
                           f'{result.stderr.decode()[-500:]}')
    factor = values.reshape(len(sensors), len(directions), 3) @ RGB_WEIGHTS
    factor = factor / SUN_SOLID_ANGLE_SR
    _CACHE[key] = factor
    return factor


def illuminance(coefficients: Union[DaylightCoefficients, FloatArray],
                sky: FloatArray) -> FloatArray:
    """Illuminance [lx] (N, H) of coefficients (N, P, 3) under sky vectors (P, H, 3)."""
    values = cast(FloatArray, getattr(coefficients, 'values', coefficients))
    rgb = np.einsum('npc,phc->nhc', values, sky)
    return LUMINOUS_EFFICACY * rgb @ RGB_WEIGHTS


def closure_weights(states: Sequence[float], closure_per_hour: npt.ArrayLike) -> FloatArray:
    """Weights (H, S) of the computed closure states for each hour's closure.

    Linear between the two nearest states; a closure outside their range takes the nearest.
    """
    states = np.asarray(states, dtype=float)
    closure = np.clip(np.asarray(closure_per_hour, dtype=float).ravel(), states.min(),
                      states.max())
    weights = np.zeros((closure.size, len(states)))
    if len(states) == 1:
        weights[:, 0] = 1.0
        return weights
    order = np.argsort(states)
    ordered = states[order]
    upper = np.clip(np.searchsorted(ordered, closure, side='left'), 1, len(ordered) - 1)
    low, high = ordered[upper - 1], ordered[upper]
    share = (closure - low) / (high - low)
    rows = np.arange(closure.size)
    weights[rows, order[upper - 1]] = 1.0 - share
    weights[rows, order[upper]] += share
    return weights


def hourly_weights(states: Sequence[float], step_of_year: npt.ArrayLike, closure: npt.ArrayLike,
                   steps_per_hour: int = 6, hours: int = 8760) -> FloatArray:
    """Mean state weights (hours, S) over each hour's steps; NaN rows for hours without any.

    ``step_of_year`` (T,) numbers the building simulation's steps from the first of
    1 January, ``closure`` (T,) the facade's closure over each. Illuminance is linear in the
    weights, so an hour's illuminance under the hour's sky is that of its mean weights.
    """
    steps = np.asarray(step_of_year, dtype=np.int64)
    weights = closure_weights(states, closure)
    hour = steps // steps_per_hour
    if steps.size and (hour.min() < 0 or hour.max() >= hours):
        raise ValueError(f'steps outside the year of {hours} hours')
    total = np.zeros((hours, len(states)))
    count = np.zeros(hours)
    np.add.at(total, hour, weights)
    np.add.at(count, hour, 1.0)
    with np.errstate(invalid='ignore', divide='ignore'):
        return total / count[:, None]


#: Hemisphere samples of the sky seen directly (the black scene, one bounce, cheap) and of
#: the eye's full coefficients (one sensor): the sun spread over the sky patches is seen
#: through the facade's gaps from both matrices, and their difference is only as good as
#: their sampling (at 4096 samples the eye's illuminance varied by up to a third between
#: runs of the same closure).
FINE_SAMPLES = 65536


def _with(params: Sequence[str], bounces: Optional[int] = None,
          samples: Optional[int] = None) -> tuple[str, ...]:
    """``params`` with ``-ab bounces`` and at least ``samples`` ambient divisions."""
    params = list(params)
    for flag, value in (('-ab', bounces), ('-ad', samples)):
        if value is None:
            continue
        if flag in params:
            at = params.index(flag) + 1
            params[at] = str(value if flag == '-ab' else max(int(params[at]), value))
        else:
            params += [flag, str(value)]
    return tuple(params)


def eye_sensor(room: 'Room', distance_m: float = 2.0, height_m: float = 1.2) -> FloatArray:
    """Return the glare view (1, 6): seated eye height, ``distance_m`` from the window, facing it.

    Mid-width of the room, looking horizontally at the window (the worst case of a desk
    facing the facade), in the scene frame.
    """
    rotation = room_to_scene(room)
    point = rotation @ np.array([0.0, distance_m, height_m])
    direction = rotation @ np.array([0.0, -1.0, 0.0])
    return np.concatenate([point, direction])[None, :]


def simplified_dgp(vertical_illuminance_lx: npt.ArrayLike) -> FloatArray:
    """Simplified daylight glare probability ``DGPs = 6.22e-5 Ev + 0.184`` [-], at most 1.

    Wienold (2007) [#]_; ``Ev`` the vertical illuminance at the eye [lx]. Valid without the
    sun's disc or its specular reflections in view: with the sun seen, its illuminance at
    the eye (typically tens of klx) is in ``Ev`` and the hour counts as glare whatever the
    contrast, which errs on the side of glare.

    .. [#] Wienold, J., "Dynamic simulation of blind control strategies for visual comfort
       and energy balance analysis", Building Simulation 2007, Beijing, 1197-1204.
    """
    return np.minimum(6.22e-5 * np.asarray(vertical_illuminance_lx, dtype=float) + 0.184,
                      1.0)


@dataclass(frozen=True)
class DaylightYear:
    """Hourly daylight of a room over the office hours of a weather file."""

    hours: np.ndarray
    """(H,) record index (hour of the year, 0-based) of each row."""
    illuminance_lx: np.ndarray
    """(H, N) work-plane illuminance, sun, sky and interreflections [lx]."""
    direct_lx: np.ndarray
    """(H, N) the sun's direct illuminance alone (LM-83's ASE quantity) [lx]."""
    eye_lx: np.ndarray
    """(H,) vertical illuminance at the eye of :func:`eye_sensor` [lx]."""
    sun_in_view: np.ndarray
    """(H,) bool: the sun's disc is seen from the eye (direct illuminance above 1 lx)."""
    grid_shape: Optional[tuple] = None
    """Rows (from the window back) and columns of the work-plane sensors."""

    @property
    def dgp(self) -> FloatArray:
        """(H,) simplified daylight glare probability at the eye [-] (:func:`simplified_dgp`)."""
        return simplified_dgp(self.eye_lx)


class DaylightModel:
    """The room's daylight for a facade at any mix of closure states, by matrices.

    Three matrices per closure state of ``states`` (the facade's folded geometry at that
    closure, :func:`facade_triangles`): the daylight coefficients of the full scene
    (``rcontrib``, :data:`MATRIX_PARAMS`), those of the same scene with every opaque surface
    black and one ambient bounce (the sky patches seen directly, through the glass), and
    the sun factors of every office hour's sun in front of the facade
    (:func:`sun_coefficients`). The illuminance of an hour is

    ``E = 179 [C_full (sky + sun) - C_direct sun]_v + E_dn f_sun``,

    the sky and everything reflected by the full coefficients, the sun's direct part taken
    out of the patches it was spread over and put back at its exact direction (the
    separation of the five-phase method [#]_, with the sun at the hour's own position
    instead of the nearest patch of a finer sky). A state's year is computed once per
    weather file; an hour between states interpolates linearly between the two nearest.

    Parameters
    ----------
    room : Room
    facade : Facade or None
        ``None``: the bare window.
    states : sequence of float
        Closures at which the matrices are computed (default 0, 0.1, ..., 1).
    spacing_m : float
        Work-plane grid spacing (:func:`sensor_grid`).
    params : tuple
        ``rcontrib`` ray parameters of the full coefficients.

    .. [#] McNeil, A., "The five-phase method for simulating complex fenestration with
       Radiance", LBNL (2013).
    """

    def __init__(self, room: 'Room', facade: Optional['Facade'] = None,
                 states: Optional[Sequence[float]] = None, spacing_m: float = 0.6,
                 params: Sequence[str] = MATRIX_PARAMS, processes: int = 2,
                 progress: Optional[Callable[[str], None]] = None) -> None:
        self.room = room
        self.facade = facade
        if facade is None:
            states = (1.0,)
        self.states = tuple(float(s) for s in (np.linspace(0.0, 1.0, 11) if states is None
                                               else states))
        if not self.states or any(not 0.0 <= s <= 1.0 for s in self.states):
            raise ValueError(f'states must be closures in [0, 1], got {self.states}')
        self.sensors = sensor_grid(room, spacing_m=spacing_m)
        across, depth = grid_axes(room, spacing_m)
        self.grid_shape = (len(depth), len(across))
        """Rows (from the window back) and columns of the work-plane grid."""
        self.eye = eye_sensor(room)
        self.params = tuple(params)
        self.processes = processes
        self.say = progress or (lambda text: None)
        self._years: dict[tuple[int, float], tuple[FloatArray, FloatArray]] = {}
        self._scenes: dict[tuple[float, bool], str] = {}

    def scene(self, state: float, black: bool = False) -> str:
        """Radiance scene text at closure ``state`` (opaque surfaces black if ``black``)."""
        key = (state, black)
        if key not in self._scenes:
            triangles = None if self.facade is None else facade_triangles(
                self.facade, state, self.room)
            reflectances = dict.fromkeys(REFLECTANCES, 0.0) if black else None
            self._scenes[key] = radiance_scene(self.room, triangles, reflectances=reflectances)
        return self._scenes[key]

    def state_year(self, weather: SkyYear, state: float) -> tuple[FloatArray, FloatArray]:
        """(E, E_sun) of every office hour at closure ``state``: (H, N + 1) each [lx].

        The last column is the eye's vertical illuminance.
        """
        key = (id(weather), state)
        if key in self._years:
            return self._years[key]
        office = weather.office
        rays = np.concatenate([self.sensors, self.eye])
        grid = daylight_coefficients(self.scene(state), self.sensors, params=self.params,
                                     processes=self.processes).values
        eye = daylight_coefficients(self.scene(state), self.eye,
                                    params=_with(self.params, samples=FINE_SAMPLES),
                                    processes=self.processes).values
        full = np.concatenate([grid, eye])
        direct = daylight_coefficients(self.scene(state, black=True), rays,
                                       params=_with(self.params, 1, FINE_SAMPLES),
                                       processes=self.processes)
        sky, sun = weather.sky[:, office], weather.sun[:, office]
        diffuse = illuminance(full, sky) - illuminance(direct, sun)
        enu = weather.sun_enu[office]
        normal = room_to_scene(self.room) @ np.array([0.0, -1.0, 0.0])
        lit = (enu[:, 2] > 0.0) & (enu @ normal > 0.0) & (weather.sun_illuminance_lx[office]
                                                          > 0.0)
        factor = np.zeros((len(rays), office.sum()))
        factor[:, lit] = sun_coefficients(self.scene(state), rays, enu[lit],
                                          processes=self.processes)
        sunlight = factor * weather.sun_illuminance_lx[office][None, :]
        result = (np.maximum(diffuse + sunlight, 0.0).T, sunlight.T)
        self._years[key] = result
        return result

    def year(self, weather: SkyYear, weights: Optional[npt.ArrayLike] = None) -> DaylightYear:
        """:class:`DaylightYear` of the office hours under hourly state ``weights``.

        ``weights`` (8760, S) as :func:`hourly_weights` gives (rows of NaN: hours outside
        the simulated period, left out); ``None`` with a single state.
        """
        office = np.flatnonzero(weather.office)
        if weights is None:
            if len(self.states) != 1:
                raise ValueError('weights are needed with more than one state')
            weights = np.ones((len(weather.hour), 1))
        weights = np.asarray(weights, dtype=float)[office]
        kept = np.all(np.isfinite(weights), axis=1)
        total = 0.0
        sun = 0.0
        for index, state in enumerate(self.states):
            share = weights[kept, index][:, None]
            if not np.any(share):
                continue
            self.say(f'daylight: closure {state:.2f}')
            both, sunlight = self.state_year(weather, state)
            total = total + share * both[kept]
            sun = sun + share * sunlight[kept]
        total = np.asarray(total)
        sun = np.asarray(sun)
        return DaylightYear(hours=office[kept], illuminance_lx=total[:, :-1],
                            direct_lx=sun[:, :-1], eye_lx=total[:, -1],
                            sun_in_view=sun[:, -1] > 1.0, grid_shape=self.grid_shape)


class CandidateDaylight:
    """The room's daylight and glare at every candidate closure, hour by hour.

    For :class:`~flectofold_model.scheduling.objective.RoomAware`: called with a step's
    start [s, UTC], it returns ``(daylit, glare)`` (K,) for the candidate closures, the share
    of the work plane at 300 lx or more and 1 where the eye's DGP reaches :data:`GLARE_DGP`,
    in the weather file's hour holding that instant (what sensors in the room would measure
    now); zeros outside office hours. Candidates between the model's states take the linear
    mix of the two nearest.
    """

    def __init__(self, model: DaylightModel, skies: SkyYear, candidates: npt.ArrayLike) -> None:
        self.model = model
        self.skies = skies
        weights = closure_weights(model.states, candidates)
        office = np.flatnonzero(skies.office)
        self.row_of_hour = np.full(len(skies.hour), -1)
        self.row_of_hour[office] = np.arange(office.size)
        lit = 0.0
        eye = 0.0
        for index, state in enumerate(model.states):
            if np.any(weights[:, index]):
                total = model.state_year(skies, state)[0]
                lit = lit + np.outer((total[:, :-1] >= 300.0).mean(axis=1), weights[:, index])
                eye = eye + np.outer(total[:, -1], weights[:, index])
        self.daylit = np.asarray(lit)
        """(office hours, K) share of the work plane at 300 lx or more [-]."""
        self.glare = (simplified_dgp(eye) >= GLARE_DGP).astype(float)
        """(office hours, K) 1 where the eye's DGP reaches :data:`GLARE_DGP`."""
        self.start_s = float(skies.epoch_s()[0] - 1800.0)

    def __call__(self, start_s: float) -> tuple[FloatArray, FloatArray]:
        """Return ``(daylit, glare)`` (K,) for the hour holding ``start_s`` [s, UTC]."""
        hour = int(math.floor((start_s - self.start_s) / 3600.0))
        row = self.row_of_hour[hour] if 0 <= hour < self.row_of_hour.size else -1
        if row < 0:
            return np.zeros(self.daylit.shape[1]), np.zeros(self.daylit.shape[1])
        return self.daylit[row], self.glare[row]


#: DGP from which an hour counts as glare: "disturbing" or worse (Wienold 2009).
GLARE_DGP = 0.40


@dataclass(frozen=True)
class DaylightFigures:
    """A strategy's daylight and glare over the office hours of its period."""

    office_hours: int
    sda: float
    """sDA300/50%: share of sensors at 300 lx or more in half the hours [-]."""
    ase: float
    """ASE1000,250h: share of sensors with over 1000 lx of direct sun in over 250 hours [-]."""
    udi: float
    """UDI 100-2000 lx: mean share of sensor-hours in the useful range [-]."""
    udi_short: float
    """Mean share of sensor-hours below 100 lx [-]."""
    udi_exceeded: float
    """Mean share of sensor-hours above 2000 lx [-]."""
    mean_lx: float
    """Mean work-plane illuminance over sensors and hours [lx]."""
    glare_hours: int
    """Office hours with DGP at or above :data:`GLARE_DGP`."""
    glare_autonomy: float
    """Share of office hours below :data:`GLARE_DGP` [-]."""
    sun_in_view_hours: int
    """Office hours with the sun's disc seen from the eye."""
    autonomy_by_sensor: np.ndarray
    """(N,) share of the hours each sensor has 300 lx or more [-] (the sDA map)."""
    grid_shape: Optional[tuple]
    """Rows (from the window back) and columns of those sensors."""
    hours: np.ndarray
    """(H,) hour of the year of each office hour kept."""
    dgp: np.ndarray
    """(H,) DGP at the eye each office hour [-]."""


def daylight_figures(year: DaylightYear) -> DaylightFigures:
    """Reduce a :class:`DaylightYear` to its :class:`DaylightFigures`."""
    lux = year.illuminance_lx
    dgp = year.dgp
    count = len(year.hours)
    if not count:
        raise ValueError('no office hours in the period')
    return DaylightFigures(
        office_hours=count, sda=spatial_daylight_autonomy(lux),
        ase=annual_sunlight_exposure(year.direct_lx), udi=useful_daylight(lux),
        udi_short=float((lux < 100.0).mean()), udi_exceeded=float((lux > 2000.0).mean()),
        mean_lx=float(lux.mean()), glare_hours=int((dgp >= GLARE_DGP).sum()),
        glare_autonomy=float((dgp < GLARE_DGP).mean()),
        sun_in_view_hours=int(year.sun_in_view.sum()),
        autonomy_by_sensor=(lux >= 300.0).mean(axis=0), grid_shape=year.grid_shape,
        hours=year.hours, dgp=dgp)


def spatial_daylight_autonomy(illuminance_lx: npt.ArrayLike, threshold_lx: float = 300.0,
                              time_fraction: float = 0.5) -> float:
    """Return sDA (0-1): sensors at ``threshold_lx`` or more in ``time_fraction`` of hours.

    ``illuminance_lx`` is (H hours, N sensors). IES LM-83-12: sDA300/50%.
    """
    values = np.asarray(illuminance_lx, dtype=float)
    met = (values >= threshold_lx).mean(axis=0)
    return float((met >= time_fraction).mean())


def useful_daylight(illuminance_lx: npt.ArrayLike, low_lx: float = 100.0,
                    high_lx: float = 2000.0) -> float:
    """Return UDI (0-1), the mean over sensors of the share of hours with ``low <= E <= high`` lx.

    The 'fell short' and 'exceeded' shares are those of ``E < low`` and ``E > high`` (Nabil &
    Mardaljevic 2005); both bounds count as useful here.
    """
    values = np.asarray(illuminance_lx, dtype=float)
    return float(((values >= low_lx) & (values <= high_lx)).mean())


def annual_sunlight_exposure(direct_illuminance_lx: npt.ArrayLike, threshold_lx: float = 1000.0,
                             hours: int = 250) -> float:
    """Return ASE (0-1): sensors with direct sun above ``threshold_lx`` over ``hours`` hours.

    ``direct_illuminance_lx`` (H, N) is the direct sun alone (IES LM-83-12: ``-ab 0``, with
    operable shading open).
    """
    values = np.asarray(direct_illuminance_lx, dtype=float)
    return float(((values > threshold_lx).sum(axis=0) > hours).mean())


def point_illuminance(scene: str, sensors: npt.ArrayLike, weather: SkyYear, record: int,
                      params: Sequence[str] = MATRIX_PARAMS, processes: int = 2) -> FloatArray:
    """Illuminance [lx] (N,) by ``rtrace -I`` under the sky and sun of one weather record.

    :func:`gendaylit_sky` (the sun at its exact position), traced with the same ``params``
    and no ambient cache (``-aa 0``): an independent check of the matrix method.
    """
    environment = _radiance()
    with tempfile.TemporaryDirectory(prefix='flectofold_rt_') as folder:
        octree = _octree(scene, folder, gendaylit_sky(weather, record))
        result = subprocess.run(['rtrace', '-h', '-I', '-n', str(processes), '-aa', '0',
                                 *params, octree], input=_rays(sensors), capture_output=True,
                                check=True, text=True, env=environment)
    rgb = np.array(result.stdout.split(), dtype=float).reshape(-1, 3)
    return LUMINOUS_EFFICACY * rgb @ RGB_WEIGHTS


def gendaylit_sky(weather: SkyYear, record: int) -> str:
    """Radiance text of the Perez sky and sun of one record (``gendaylit -W``), with glows.

    ``gendaylit month day hour -a lat -o lon -m meridian -W dni dhi -O 0`` (Radiance
    longitudes west positive; the record's mid-hour standard time, as ``gendaymtx`` uses).
    """
    environment = _radiance()
    command = ['gendaylit', str(weather.month[record]), str(weather.day[record]),
               f'{weather.hour[record]:.3f}', '-a', f'{weather.latitude_deg:.4f}',
               '-o', f'{-weather.longitude_deg:.4f}', '-m', f'{-15.0 * weather.utc_offset_h:.1f}',
               '-W', f'{weather.dni_w_m2[record]:g}', f'{weather.dhi_w_m2[record]:g}', '-O', '0']
    sky = subprocess.run(command, capture_output=True, check=True, text=True,
                         env=environment).stdout
    return sky + ('skyfunc glow sky_glow 0 0 4 1 1 1 0\n'
                  'sky_glow source sky 0 0 4 0 0 1 180\n'
                  'skyfunc glow ground_glow 0 0 4 1 1 1 0\n'
                  'ground_glow source ground 0 0 4 0 0 -1 180\n')


#: ``rpict`` parameters of the glare check's image: three bounces with an ambient cache.
IMAGE_PARAMS = ('-ab', '3', '-ad', '2048', '-as', '512', '-aa', '0.15', '-ar', '128')


def evalglare_at(scene: str, eye: npt.ArrayLike, weather: SkyYear, record: int,
                 resolution: int = 300,
                 params: Sequence[str] = IMAGE_PARAMS) -> tuple[float, float]:
    """DGP and vertical illuminance [lx] by ``evalglare`` at one record, an independent check.

    An angular fisheye (``-vta -vh 180 -vv 180``) rendered by ``rpict`` from ``eye`` (1, 6)
    under :func:`gendaylit_sky`, evaluated by ``evalglare`` (Wienold and Christoffersen's DGP
    with every glare source it detects); returns ``(dgp, ev_lx)``.
    """
    environment = _radiance()
    eye = np.asarray(eye, dtype=float).reshape(6)
    up = (0.0, 0.0, 1.0)
    with tempfile.TemporaryDirectory(prefix='flectofold_glare_') as folder:
        octree = _octree(scene, folder, gendaylit_sky(weather, record))
        image = os.path.join(folder, 'view.hdr')
        with open(image, 'wb') as stream:
            subprocess.run(['rpict', '-vta', '-vh', '180', '-vv', '180',
                            '-vp', *(f'{v:.6f}' for v in eye[:3]),
                            '-vd', *(f'{v:.6f}' for v in eye[3:]),
                            '-vu', *(f'{v:g}' for v in up), '-x', str(resolution), '-y',
                            str(resolution), '-ps', '1', *params, octree],
                           stdout=stream, check=True, env=environment,
                           stderr=subprocess.DEVNULL)
        result = subprocess.run(['evalglare', '-d', image], capture_output=True, text=True,
                                check=True, env=environment)
    return _evalglare_output(result.stdout)


def _evalglare_output(text: str) -> tuple[float, float]:
    """(dgp, ev) from ``evalglare -d`` output: its ``dgp,av_lum,E_v,...`` header and line."""
    lines = text.splitlines()
    for index, line in enumerate(lines):
        if line.startswith('dgp,'):
            names = [name.strip() for name in line.split(':')[0].split(',')]
            values = [float(v) for v in line.split(':', 1)[1].split()] if ':' in line else \
                [float(v) for v in lines[index + 1].split()]
            record = dict(zip(names, values))
            return record['dgp'], record['E_v']
    raise RuntimeError(f'no DGP in the evalglare output: {text[-500:]}')
