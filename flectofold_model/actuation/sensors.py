"""The pressure sensors of N cushion circuits: lag, offset, noise, and their injected faults.

Each circuit has a cushion pressure sensor (a first-order lag behind the true pressure, a
constant offset and Gaussian noise) and a supply pressure sensor (no lag, the same noise).
Both draw their noise from one seeded generator, one draw per panel on every read, so the
same seed and the same reads give the same readings, and a fault of one panel does not shift
the noise of the others.
"""

import math
from typing import Any, Union

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import BoolArray, FloatArray, panel_mask, real_scalar
from flectofold_model.actuation.circuit import PlantParameters

#: What :meth:`CushionSensors.kernel_view` returns: offset [Pa], cushion noise (N,) [Pa], stuck
#: and dropped-out masks (N,), last readings (N,) [Pa], supply noise [Pa].
SensorView = tuple[float, FloatArray, BoolArray, BoolArray, FloatArray, float]


class CushionSensors:
    """Sensor state of ``count`` circuits of one :class:`~.circuit.PlantParameters`.

    ``initial_pa`` (N,) is the absolute cushion pressure the lag starts settled on.
    """

    # set by clear_faults
    _stuck: BoolArray
    _dropout: BoolArray
    noise_pa: FloatArray

    def __init__(self, parameters: PlantParameters, count: int,
                 seed: Union[int, np.integer[Any]], initial_pa: FloatArray) -> None:
        self._parameters = parameters
        self._count = count
        self._rng = np.random.default_rng(int(seed))
        self.lagged_pa = initial_pa.copy()
        """The lagged true pressure, before offset and noise (N,) [Pa]."""
        self._last_reading_pa = self.lagged_pa + parameters.sensor_offset_pa
        self._drawn: FloatArray = np.empty(0)
        self.clear_faults()

    def track(self, p0: FloatArray, p1: FloatArray, h: float) -> None:
        """Advance the lag over ``h`` [s] for a pressure going linearly from ``p0`` to ``p1``.

        Exact for that pressure: ``s(h) = p1 + (s0 - p0) a - (p1 - p0) tau (1 - a) / h`` with
        ``a = exp(-h / tau)``, stable for any time constant; ``tau = 0`` gives ``s = p1``.
        """
        tau = self._parameters.sensor_lag_s
        if tau == 0.0:
            self.lagged_pa = p1.copy()
            return
        decay = math.exp(-h / tau)
        lagged = self.lagged_pa
        self.lagged_pa = p1 + (lagged - p0) * decay - (p1 - p0) * (tau * (1.0 - decay) / h)

    def read(self) -> FloatArray:
        """Measured absolute cushion pressure, ``(N,)`` [Pa].

        The lagged true pressure plus ``sensor_offset_pa`` plus Gaussian noise of standard
        deviation :attr:`noise_pa` (``sensor_noise_pa`` unless raised). A stuck sensor repeats
        its last reading exactly (before the first read, the noise-free initial one); a
        dropped-out sensor reads NaN.
        """
        noise = self._normals(self._count) * self.noise_pa
        reading = self.lagged_pa + self._parameters.sensor_offset_pa + noise
        reading = np.where(self._stuck, self._last_reading_pa, reading)
        reading[self._dropout] = np.nan
        self._last_reading_pa = np.where(self._stuck, self._last_reading_pa, reading)
        return reading

    def read_supply(self, supply_pa: FloatArray) -> FloatArray:
        """Measured absolute supply pressure of a true ``supply_pa`` (N,) [Pa]: no lag."""
        noise = self._normals(self._count) * self._parameters.sensor_noise_pa
        return supply_pa + noise

    def draw_ahead(self, reads: int) -> FloatArray:
        """Return the standard normal draws of the next ``reads`` reads (reads, 2, N).

        Row ``[r, 0]`` is what the ``r``-th :meth:`read` from now would draw, ``[r, 1]`` the
        :meth:`read_supply` after it: a compiled caller that reads both once per period uses
        them in this order, and hands back what it did not use (:meth:`put_back`), so that
        the readings are the ones the reads would have given.
        """
        return self._normals(2 * reads * self._count).reshape(reads, 2, self._count)

    def put_back(self, draws: npt.ArrayLike) -> None:
        """Return draws taken with :meth:`draw_ahead` but not used: the next reads take them."""
        self._drawn = np.concatenate((np.ravel(draws), self._drawn))

    def kernel_view(self) -> SensorView:
        """Offset, cushion noise (N,), stuck and dropped-out masks, last readings, supply noise.

        Pressures in Pa; the arrays (N,) live.
        """
        parameters = self._parameters
        return (parameters.sensor_offset_pa, self.noise_pa, self._stuck, self._dropout,
                self._last_reading_pa, parameters.sensor_noise_pa)

    def _normals(self, count: int) -> FloatArray:
        """Return the next ``count`` standard normal draws, those drawn ahead first."""
        if not self._drawn.size:
            return self._rng.standard_normal(count)
        if self._drawn.size < count:
            self._drawn = np.concatenate(
                (self._drawn, self._rng.standard_normal(count - self._drawn.size)))
        taken, self._drawn = self._drawn[:count], self._drawn[count:]
        return taken

    def inject_stuck(self, panels: npt.ArrayLike) -> None:
        """Freeze the cushion sensor of ``panels`` on the value it returned last."""
        self._stuck = self._stuck | panel_mask(panels, self._count)

    def inject_dropout(self, panels: npt.ArrayLike) -> None:
        """Make the cushion sensor of ``panels`` read NaN."""
        self._dropout = self._dropout | panel_mask(panels, self._count)

    def inject_noise(self, panels: npt.ArrayLike, noise_pa: float) -> None:
        """Give the cushion sensor of ``panels`` noise of standard deviation ``noise_pa`` [Pa]."""
        noise_pa = real_scalar('noise_pa', noise_pa)
        if noise_pa < 0.0:
            raise ValueError(f'noise_pa must not be negative, got {noise_pa:g} Pa')
        self.noise_pa = np.where(panel_mask(panels, self._count), noise_pa, self.noise_pa)

    def clear_faults(self) -> None:
        """Remove the sensor faults: the sensors read live values again, at their own noise."""
        self._stuck = np.zeros(self._count, dtype=bool)
        self._dropout = np.zeros(self._count, dtype=bool)
        self.noise_pa = np.full(self._count, self._parameters.sensor_noise_pa)
        """Standard deviation of each cushion sensor's noise (N,) [Pa]."""
