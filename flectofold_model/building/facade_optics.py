"""What the folded facade lets through to the window behind it: beam and diffuse transmittance.

The window behind a facade of Flectofold panels sees the direct sun through whatever the
panels leave uncovered. From the facade's own ray casting (the shading table of its median
panel, :class:`~flectofold_model.shading.table.ShadingTable`, as the coordinator uses it):

- **beam**: ``tau_b = sum_p w_p (1 - b_p(c_p, s_p))``, the footprint-weighted share of the
  direct beam that passes the panels at their closures ``c_p`` and the sun ``s_p`` in each
  panel's frame (``b`` the blocked fraction; a sun behind the facade reaches no window and
  counts as passing);
- **diffuse**: for an isotropic sky, the cosine-weighted mean of ``1 - b(c, s)`` over the
  hemisphere in front of a panel, ``tau_d(c) = (1/pi) int (1 - b) cos theta d omega``,
  estimated on a fixed cosine-weighted quasi-random set of directions (a Fibonacci lattice
  [1]_): a property of the closure alone.

A building model that takes one transmittance for both (EnergyPlus's shading surfaces:
"the same for solar and visible" [2]_) is given the irradiance-weighted mix
:func:`effective_transmittance`, so that the solar energy passing the facade is right. Light
reflected by the ground reaches the window from below through the same panels: it passes in
the share ``tau_d`` (the panels are nearly symmetric about their plane's horizontal).

References
----------
.. [1] Gonzalez, A., "Measurement of areas on a sphere using Fibonacci and
   latitude-longitude lattices", Mathematical Geosciences 42 (2010) 49-64.
.. [2] US DOE, EnergyPlus Input Output Reference, "Shading:Building:Detailed", field
   "Transmittance Schedule Name".
"""

from typing import Optional

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, real_array
from flectofold_model.facade.description import Facade
from flectofold_model.shading.table import ShadingTable

#: Directions of the hemisphere sample for the diffuse transmittance.
DIFFUSE_SAMPLES = 4096


def cosine_directions(count: int = DIFFUSE_SAMPLES) -> FloatArray:
    """Return unit directions (count, 3) on the front hemisphere (z > 0), cosine-weighted.

    A Fibonacci lattice on the unit disc lifted to the hemisphere (Malley's method): the
    mean of a function over them estimates ``(1/pi) int f cos theta d omega``.
    """
    index = np.arange(count) + 0.5
    radius = np.sqrt(index / count)
    angle = np.pi * (3.0 - np.sqrt(5.0)) * index
    x, y = radius * np.cos(angle), radius * np.sin(angle)
    return np.stack([x, y, np.sqrt(np.maximum(1.0 - x * x - y * y, 0.0))], axis=-1)


def diffuse_transmittance(table: ShadingTable, count: int = DIFFUSE_SAMPLES) -> FloatArray:
    """Isotropic-sky diffuse transmittance (C,) of each candidate closure of ``table``."""
    blocked = table.blocked_fractions(cosine_directions(count))
    return 1.0 - blocked.mean(axis=0)


def beam_transmittance(facade: Facade, table: ShadingTable, closure: npt.ArrayLike,
                       sun_enu: npt.ArrayLike, weights: Optional[FloatArray] = None) -> float:
    """Footprint-weighted beam transmittance of the facade at ``closure`` (N,) [-].

    ``sun_enu`` (3,) the unit vector toward the sun; ``weights`` (N,) the panels' footprint
    shares (default: equal). Closures between the table's candidates are interpolated.
    """
    closure = real_array('closure', closure).reshape(-1)
    if closure.size != len(facade):
        raise ValueError(f'closure must have one entry per panel ({len(facade)}), got '
                         f'{closure.size}')
    sun = facade.sun_in_panel_frames(real_array('sun_enu', sun_enu).reshape(3))
    passing = 1.0 - interpolated(table.closures, table.blocked_fractions(sun), closure)
    weights = np.full(closure.size, 1.0 / closure.size) if weights is None else weights
    return float(passing @ weights)


def interpolated(closures: FloatArray, values: FloatArray, closure: FloatArray) -> FloatArray:
    """Values (N,) of rows (N, C) over candidate ``closures`` (C,) at ``closure`` (N,), linear."""
    position = np.interp(closure, closures, np.arange(closures.size))
    lower = np.clip(np.floor(position).astype(int), 0, closures.size - 2)
    fraction = position - lower
    rows = np.arange(values.shape[0])
    return values[rows, lower] + fraction * (values[rows, lower + 1] - values[rows, lower])


def effective_transmittance(beam: float, diffuse: float, beam_w_m2: float,
                            diffuse_w_m2: float) -> float:
    """One transmittance that passes the right solar energy: the irradiance-weighted mix.

    ``beam``, ``diffuse`` transmittances [-]; ``beam_w_m2``, ``diffuse_w_m2`` the beam and
    diffuse irradiance on the facade's plane [W/m2]. Without either: the diffuse one.
    """
    total = beam_w_m2 + diffuse_w_m2
    if not total > 0.0:
        return float(diffuse)
    return float((beam * beam_w_m2 + diffuse * diffuse_w_m2) / total)
