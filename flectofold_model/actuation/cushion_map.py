"""The static actuation map as a table, cheap enough for a plant's inner loop.

:class:`CushionMap` samples an :class:`~.statics.ActuationModel` at states evenly spaced in
closure and interpolates volume, compliance, pressure and closure between them.
"""

import numpy as np

from flectofold_model.actuation.statics import ActuationModel, DERIVATIVE_STEP


class CushionMap:
    """Tabulated static map of an :class:`ActuationModel`, cheap enough for a plant's inner loop.

    Calling it with gauge pressures (N,) returns the cushion volume [m3] and its compliance
    ``dV/dp`` [m3/Pa] per panel, interpolated between ``samples`` states evenly spaced in closure.
    Outside ``[0, closed pressure]`` the panel rests on a stop: the volume holds and the
    compliance is zero. Within the first and last table intervals the compliance ramps to zero
    at the stop, as a cushion lifting off (or settling onto) a stop does; a jump there would
    cost a fixed-step integrator its order of accuracy. :meth:`closure` interpolates the
    closure the same way.
    """

    def __init__(self, model, samples=129):
        if not isinstance(model, ActuationModel):
            raise TypeError(f'CushionMap needs an ActuationModel, got {type(model).__name__}')
        if isinstance(samples, bool) or not isinstance(samples, int) or samples < 3:
            raise ValueError(f'samples must be an integer of at least 3, got {samples!r}')
        closures = np.linspace(0.0, 1.0, samples)
        k = np.stack([model.fold.state_from_closure(c).elastica_k for c in closures], axis=1)
        step = DERIVATIVE_STEP
        index = np.repeat(model._all, samples)
        flat_k = k.ravel()
        pressure = model._pressure(flat_k, index).reshape(k.shape)
        volume = model._volume(flat_k, index).reshape(k.shape)
        pressure_rate = (model._pressure(flat_k + step, index)
                         - model._pressure(flat_k - step, index)).reshape(k.shape) / (2 * step)
        volume_rate = (model._volume(flat_k + step, index)
                       - model._volume(flat_k - step, index)).reshape(k.shape) / (2 * step)
        if np.any(np.diff(pressure, axis=1) <= 0):
            raise ValueError('the pressure map is not monotone in closure: the panel would snap')
        self.pressure_pa = pressure
        self.volume_m3 = volume
        self.compliance_m3_per_pa = volume_rate / pressure_rate
        self.closures = closures

    def __call__(self, gauge_pressure_pa):
        pressure = np.asarray(gauge_pressure_pa, dtype=np.float64)
        lower, fraction = self._locate(pressure)
        volume = _between(self.volume_m3, lower, fraction)
        compliance = _between(self.compliance_m3_per_pa, lower, fraction)
        table = self.pressure_pa
        off_open_stop = np.clip(pressure / table[:, 1], 0.0, 1.0)
        off_closed_stop = np.clip((table[:, -1] - pressure) / (table[:, -1] - table[:, -2]),
                                  0.0, 1.0)
        return volume, compliance * off_open_stop * off_closed_stop

    def pressure_for_closure(self, closure):
        """Gauge pressure (N,) [Pa] that holds closures (N,) in [0, 1], by interpolation."""
        position = np.asarray(closure, dtype=np.float64) / (self.closures[1] - self.closures[0])
        lower = np.minimum(position.astype(np.intp), self.closures.size - 2)
        return _between(self.pressure_pa, lower, position - lower)

    def closure(self, gauge_pressure_pa):
        """Closure (N,) at gauge pressures (N,), by the same interpolation."""
        lower, fraction = self._locate(np.asarray(gauge_pressure_pa, dtype=np.float64))
        return self.closures[lower] + fraction * (self.closures[1] - self.closures[0])

    def _locate(self, pressure):
        table = self.pressure_pa
        clipped = np.clip(pressure, table[:, 0], table[:, -1])
        lower = np.clip(np.sum(table < clipped[:, None], axis=1) - 1, 0, table.shape[1] - 2)
        rows = np.arange(table.shape[0])
        low, high = table[rows, lower], table[rows, lower + 1]
        return lower, (clipped - low) / (high - low)


def _between(table, lower, fraction):
    rows = np.arange(table.shape[0])
    return table[rows, lower] + fraction * (table[rows, lower + 1] - table[rows, lower])
