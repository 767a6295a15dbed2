"""The static actuation map as a table, cheap enough for a plant's inner loop.

:class:`CushionMap` samples a static actuation model (:class:`~.statics.ActuationModel` of
quad panels or :class:`~.hexagon_statics.HexagonActuationModel` of hexagonal ones) at states
evenly spaced in closure and interpolates volume, compliance, pressure and closure between
them. Panels of the same module geometry and build share one table: it is computed once per
distinct panel. The tables do not depend on the panel kind: the plant, the loops and the
compiled kernels see only them.
"""

from typing import cast, Hashable, Iterable, Optional, Self, Sequence, TypeVar

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, IntArray
from flectofold_model.actuation.static_model import StaticActuationModel

_PanelT = TypeVar('_PanelT', bound=Hashable)
#: Pressure [Pa gauge], volume [m3], compliance [m3/Pa] and apex fold angle [rad] (R, S).
Tables = tuple[FloatArray, FloatArray, FloatArray, FloatArray]
#: :meth:`CushionMap.compiled_tables`: the four tables (R, S), the rows (N,) and the closures (S,).
CompiledTables = tuple[FloatArray, FloatArray, FloatArray, FloatArray, npt.NDArray[np.int64],
                       FloatArray]


class CushionMap:
    """Tabulated static map of a static actuation model, cheap enough for a plant's inner loop.

    Calling it with gauge pressures (N,) returns the cushion volume [m3] and its compliance
    ``dV/dp`` [m3/Pa] per panel, interpolated between ``samples`` states evenly spaced in closure.
    Outside ``[0, closed pressure]`` the panel rests on a stop: the volume holds and the
    compliance is zero. Within the first and last table intervals the compliance ramps to zero
    at the stop, as a cushion lifting off (or settling onto) a stop does; a jump there would
    cost a fixed-step integrator its order of accuracy. :meth:`closure` interpolates the
    closure the same way.
    """

    def __init__(self, model: StaticActuationModel, samples: int = 129) -> None:
        if not isinstance(model, StaticActuationModel):
            raise TypeError(f'CushionMap needs an ActuationModel or a HexagonActuationModel, '
                            f'got {type(model).__name__}')
        if isinstance(samples, bool) or not isinstance(samples, int) or samples < 3:
            raise ValueError(f'samples must be an integer of at least 3, got {samples!r}')
        distinct, row = distinct_panels(model.panels)
        source = model if len(distinct) == len(model) else type(model)(
            distinct, quadrature_points=model.quadrature_points)
        closures = np.linspace(0.0, 1.0, samples)
        self._set_tables(_tables(source, closures), row, closures)

    @classmethod
    def from_tables(cls, tables: Sequence[npt.ArrayLike], row: npt.ArrayLike) -> Self:
        """Build a map from tables computed elsewhere (the structural model's, say).

        ``tables``: gauge pressure [Pa], cushion volume [m3], compliance dV/dp [m3/Pa] and
        apex fold angle [rad] of R distinct panels at S closures evenly spaced from 0 to 1, each
        (R, S); ``row`` (N,): each panel's row. Checked as the computed maps are: finite,
        pressure rising with closure, volume rising, compliance positive.
        """
        arrays = [np.array(table, dtype=np.float64) for table in tables]
        if len(arrays) != 4 or any(a.ndim != 2 or a.shape != arrays[0].shape for a in arrays):
            raise ValueError('tables must be four (R, S) arrays: pressure, volume, '
                             'compliance, fold angle')
        if arrays[0].shape[1] < 3 or not all(np.all(np.isfinite(a)) for a in arrays):
            raise ValueError('tables must be finite with at least 3 closures')
        pressure, volume, compliance, _ = arrays
        if np.any(np.diff(pressure, axis=1) <= 0):
            raise ValueError('the pressure map is not monotone in closure: the panel would snap')
        if np.any(np.diff(volume, axis=1) <= 0) or np.any(compliance <= 0):
            raise ValueError('the cushion volume must rise with closure and its compliance '
                             'be positive')
        row = np.asarray(row, dtype=np.intp)
        if row.ndim != 1 or row.size == 0 or row.min() < 0 or row.max() >= pressure.shape[0]:
            raise ValueError(f'row must index the {pressure.shape[0]} rows of the tables')
        result = cls.__new__(cls)
        result._set_tables(cast(Tables, tuple(arrays)), row,  # four, checked above
                           np.linspace(0.0, 1.0, pressure.shape[1]))
        return result

    def _set_tables(self, distinct: Tables, row: IntArray, closures: FloatArray) -> None:
        self.row = row
        self.closures = closures
        self._distinct = distinct
        pressure, volume, compliance, fold_angle = (table[self.row] for table in self._distinct)
        self.pressure_pa = pressure
        """Gauge pressure [Pa] at each panel's closure samples (N, S)."""
        self.volume_m3 = volume
        """Cushion volume [m3] there (N, S)."""
        self.compliance_m3_per_pa = compliance
        """Cushion compliance dV/dp [m3/Pa] there (N, S)."""
        self.fold_angle_rad = fold_angle
        """Flap fold angle at the crease apex [rad] there (N, S)."""
        self._compiled: Optional[CompiledTables] = None

    @property
    def distinct_count(self) -> int:
        """Number of distinct panels (module geometry and build) the tables were computed for."""
        return self._distinct[0].shape[0]

    def __call__(self, gauge_pressure_pa: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        pressure = np.asarray(gauge_pressure_pa, dtype=np.float64)
        lower, fraction = self._locate(pressure)
        volume = _between(self.volume_m3, lower, fraction)
        compliance = _between(self.compliance_m3_per_pa, lower, fraction)
        table = self.pressure_pa
        off_open_stop = np.clip(pressure / table[:, 1], 0.0, 1.0)
        off_closed_stop = np.clip((table[:, -1] - pressure) / (table[:, -1] - table[:, -2]),
                                  0.0, 1.0)
        return volume, compliance * off_open_stop * off_closed_stop

    def tables(self) -> tuple[FloatArray, FloatArray, FloatArray, IntArray]:
        """Return the distinct panels' tables and each panel's row in them.

        Pressure [Pa gauge], volume [m3] and compliance [m3/Pa], each (R, S), and the row
        (N,): what a compiled integrator needs.
        """
        return (*self._distinct[:3], self.row)

    def compiled_tables(self) -> CompiledTables:
        """Return the tables as compiled kernels take them, built once: contiguous arrays.

        Pressure [Pa gauge], volume [m3], compliance [m3/Pa] and apex fold angle [rad] of the
        distinct panels (R, S), each panel's row (N,) and the closure samples (S,).
        """
        if self._compiled is None:
            self._compiled = cast(CompiledTables, (
                *(np.ascontiguousarray(t, dtype=np.float64) for t in self._distinct),
                np.ascontiguousarray(self.row, dtype=np.int64),
                np.ascontiguousarray(self.closures, dtype=np.float64)))
        return self._compiled

    def pressure_for_closure(self, closure: npt.ArrayLike) -> FloatArray:
        """Gauge pressure (N,) [Pa] that holds closures (N,) in [0, 1], by interpolation."""
        position = np.asarray(closure, dtype=np.float64) / (self.closures[1] - self.closures[0])
        lower = np.minimum(position.astype(np.intp), self.closures.size - 2)
        return _between(self.pressure_pa, lower, position - lower)

    def closure(self, gauge_pressure_pa: npt.ArrayLike) -> FloatArray:
        """Closure (N,) at gauge pressures (N,), by the same interpolation."""
        lower, fraction = self._locate(np.asarray(gauge_pressure_pa, dtype=np.float64))
        return self.closures[lower] + fraction * (self.closures[1] - self.closures[0])

    def _locate(self, pressure: FloatArray) -> tuple[IntArray, FloatArray]:
        table = self.pressure_pa
        clipped = np.clip(pressure, table[:, 0], table[:, -1])
        lower = np.clip(np.sum(table < clipped[:, None], axis=1) - 1, 0, table.shape[1] - 2)
        rows = np.arange(table.shape[0])
        low, high = table[rows, lower], table[rows, lower + 1]
        return lower, (clipped - low) / (high - low)


def distinct_panels(panels: Iterable[_PanelT]) -> tuple[list[_PanelT], IntArray]:
    """Return the distinct panels, in first-seen order, and each panel's index among them (N,).

    Panels are compared by value (an :class:`~.statics.ActuatedPanel` is a frozen dataclass):
    the 36 modules of a facade of one module geometry are one panel, built once.
    """
    index: dict[_PanelT, int] = {}
    row = np.array([index.setdefault(panel, len(index)) for panel in panels], dtype=np.intp)
    return list(index), row


def _tables(model: StaticActuationModel, closures: FloatArray) -> Tables:
    """Pressure, volume, compliance and apex fold angle (R, S) of ``model`` at ``closures``."""
    shape, fold_angle = model.shape_table(closures)
    step = model.derivative_step
    index = np.repeat(np.arange(len(model)), closures.size)
    flat = shape.ravel()
    pressure = model.pressure(flat, index).reshape(shape.shape)
    volume = model.volume(flat, index).reshape(shape.shape)
    pressure_rate = (model.pressure(flat + step, index)
                     - model.pressure(flat - step, index)).reshape(shape.shape) / (2 * step)
    volume_rate = (model.volume(flat + step, index)
                   - model.volume(flat - step, index)).reshape(shape.shape) / (2 * step)
    if np.any(np.diff(pressure, axis=1) <= 0):
        raise ValueError('the pressure map is not monotone in closure: the panel would snap')
    return pressure, volume, volume_rate / pressure_rate, fold_angle


def _between(table: FloatArray, lower: IntArray, fraction: FloatArray) -> FloatArray:
    rows = np.arange(table.shape[0])
    return table[rows, lower] + fraction * (table[rows, lower + 1] - table[rows, lower])
