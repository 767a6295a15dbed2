"""Clear-sky direct normal irradiance: pvlib's Ineichen model, offline, and a cache of it.

``DNI_clear`` is what a forecast scales (:mod:`flectofold_model.scheduling.predictive`) and
what the day report takes for a clear day: pvlib's Ineichen-Perez model [1]_ with pvlib's
bundled monthly Linke turbidity climatology (no download). A call goes through pandas and
costs milliseconds whatever its length, so :class:`ClearSkyDni` computes a batch of instants
on a grid at a miss and interpolates linearly between them.

References
----------
.. [1] Ineichen, P. and Perez, R., "A new airmass independent formulation for the Linke
   turbidity coefficient", Solar Energy 73(3) (2002) 151-157; pvlib.clearsky.ineichen.
"""

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, real_array, real_scalar
from flectofold_model.environment.sun import Site


def clear_sky_dni(epochs: npt.ArrayLike, site: Site) -> FloatArray:
    """Clear-sky direct normal irradiance [W/m2] at POSIX times (T,) [s]: pvlib's Ineichen.

    With pvlib's bundled Linke turbidity data (monthly climatology, offline).
    """
    import pandas as pd
    from pvlib.location import Location
    times = pd.to_datetime(np.asarray(epochs, dtype=float), unit='s', utc=True)
    location = Location(site.latitude_deg, site.longitude_deg, altitude=site.elevation_m)
    return location.get_clearsky(times, model='ineichen')['dni'].to_numpy()


class ClearSkyDni:
    """:func:`clear_sky_dni` on a grid of ``step_s``, linear in between.

    ``batch`` instants of the grid are computed per miss, ``keep`` kept at most.
    """

    def __init__(self, site: Site, step_s: float, batch: int = 96, keep: int = 4096) -> None:
        self.site = site
        self.step_s = real_scalar('step_s', step_s)
        if not self.step_s > 0.0:
            raise ValueError(f'step_s must be positive, got {self.step_s:g} s')
        self.batch, self.keep = int(batch), int(keep)
        self._values: dict[int, float] = {}

    def at(self, epoch_s: npt.ArrayLike) -> FloatArray:
        """Clear-sky DNI [W/m2] at POSIX times (T,)."""
        times = np.ravel(real_array('epoch_s', epoch_s))
        position = times / self.step_s
        lower = np.floor(position).astype(np.int64)
        needed = sorted(set(lower.tolist()) | set((lower + 1).tolist()))
        missing = [k for k in needed if k not in self._values]
        if missing:
            grid = sorted(set(missing) | {missing[-1] + j for j in range(1, self.batch + 1)})
            grid = [k for k in grid if k not in self._values or k in missing]
            values = clear_sky_dni(np.array(grid, dtype=float) * self.step_s, self.site)
            self._values.update(zip(grid, values.tolist()))
            for old in list(self._values)[:max(0, len(self._values) - self.keep)]:
                if old not in needed:
                    del self._values[old]
        below = np.array([self._values[k] for k in lower.tolist()])
        above = np.array([self._values[k] for k in (lower + 1).tolist()])
        fraction = position - lower
        return below + fraction * (above - below)
