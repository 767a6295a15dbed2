"""Sun vectors on a time grid, computed a batch ahead and kept: the SPA without its overhead.

A sped-up day asks for the sun every minute of simulated time, several times a wall second,
one or a few instants at a time; :func:`~.sun.sun_vector_enu` (pvlib's SPA over pandas) costs
about the same for one instant as for hundreds (what that cost the sun node and the
coordinator: msg_docs/coordinator_node.md, section "Topics"). :class:`SunEphemeris` computes,
at a time it has not seen, that time and the next ``batch`` instants of its grid in one call,
and keeps up to ``keep`` of them. The values are the SPA's, unchanged, at each time rounded to
the millisecond.
"""

import math

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, real_array, real_scalar
from flectofold_model.environment.sun import Site, sun_vector_enu


class SunEphemeris:
    """Unit sun vectors (ENU) of one site, cached on a grid of ``step_s``.

    Parameters
    ----------
    site : Site
    step_s : float
        Spacing of the instants computed ahead of a missed one [s], ``> 0``.
    batch : int
        Instants computed ahead per miss, ``>= 0``.
    keep : int
        Instants kept at most (the oldest are dropped first), ``> batch``.
    delta_t_s : float
        TT - UT1 [s], as for :func:`~.sun.sun_vector_enu`.
    """

    def __init__(self, site: Site, step_s: float, batch: int = 240, keep: int = 4096,
                 delta_t_s: float = 67.0) -> None:
        if not isinstance(site, Site):
            raise TypeError(f'site must be a Site, got {type(site).__name__}')
        self.site = site
        self.step_s = real_scalar('step_s', step_s)
        if not self.step_s > 0.0:
            raise ValueError(f'step_s must be positive, got {self.step_s:g} s')
        for name, value in (('batch', batch), ('keep', keep)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise ValueError(f'{name} must be a non-negative integer, got {value!r}')
        if keep <= batch:
            raise ValueError(f'keep={keep} must exceed batch={batch}')
        self.batch, self.keep = batch, keep
        self.delta_t_s = real_scalar('delta_t_s', delta_t_s)
        self._vectors: dict[int, tuple[float, ...]] = {}
        self.computed = 0
        """Instants computed so far (the SPA's work)."""

    def enu(self, epoch_s: npt.ArrayLike) -> FloatArray:
        """Return the sun vectors at POSIX times ``epoch_s`` (T,), shape ``(T, 3)``."""
        keys = [_key(t) for t in np.ravel(real_array('epoch_s', epoch_s))]
        missing = [key for key in dict.fromkeys(keys) if key not in self._vectors]
        if missing:
            self._compute(missing)
        vectors = np.array([self._vectors[key] for key in keys], dtype=np.float64)
        for old in list(self._vectors)[:max(0, len(self._vectors) - self.keep)]:
            del self._vectors[old]
        return vectors.reshape(-1, 3)

    def _compute(self, missing: list[int]) -> None:
        step_ms = self.step_s * 1e3
        ahead = [missing[-1] + round(k * step_ms) for k in range(1, self.batch + 1)]
        keys = list(dict.fromkeys(missing + [key for key in ahead if key not in self._vectors]))
        vectors = sun_vector_enu(np.array(keys, dtype=np.float64) / 1e3, self.site,
                                 self.delta_t_s)
        self.computed += len(keys)
        self._vectors.update(zip(keys, map(tuple, vectors)))


def _key(epoch_s: float) -> int:
    if not math.isfinite(epoch_s):
        raise ValueError(f'epoch_s must be finite, got {epoch_s}')
    return round(epoch_s * 1e3)
