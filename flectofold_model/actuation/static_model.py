"""What the static actuation models of both panel kinds share: the maps built on ``p(shape)``.

A static model has one degree of freedom per panel, the *shape parameter* of its fold model
(the mid-rib's elastica modulus for a quad panel, the centre rise [m] for a hexagonal one).
A subclass gives the stored energy, cushion volume and holding pressure at shape parameters
for a set of panel indices (``energy``, ``volume``, ``pressure``, each ``(shape (M,),
index (M,)) -> (M,)``); this base turns them into the public maps: energy, volume and
pressure at a shape, pressure <-> closure both ways (by scipy's elementwise root finder, on
just the panels still unresolved), the reachable closure of a supply and the table of shapes
at closure samples that :class:`~.cushion_map.CushionMap` evaluates.
"""

from typing import Any, Callable, Iterable, TYPE_CHECKING, TypeVar
import warnings

import numpy as np
import numpy.typing as npt
from scipy.optimize.elementwise import find_root

from flectofold_model._validate import (FloatArray, FloatOrArray, IntArray, real_array,
                                        real_scalar)
from flectofold_model.kinematics.kinds import AnyFoldModel, Batch

_PanelT = TypeVar('_PanelT')
#: A map of a static model at shape parameters (M,) of panels ``index`` (M,): values (M,).
_ShapeMap = Callable[[FloatArray, IntArray], FloatArray]


class UnreachableClosureWarning(UserWarning):
    """A requested state needs more pressure than the supply can give."""


class StaticActuationModel:
    """The maps both static actuation models share (quad and hexagonal panels).

    Subclasses set ``panels``, ``quadrature_points``, ``fold`` (a fold model of the kind),
    ``_all`` (``arange(N)``), ``derivative_step`` (the central-difference step in the shape
    parameter), ``stiffness_step`` (the second-difference step of :meth:`stiffness_at_shape`),
    ``shape_name`` (the shape parameter's name in error messages) and
    ``closed_pressure_pa``, and define ``energy``, ``volume`` and ``pressure``.
    """

    shape_name = 'shape'
    # set by each subclass (see above)
    panels: list[Any]
    quadrature_points: int
    fold: AnyFoldModel
    _all: IntArray
    derivative_step: float
    stiffness_step: float
    closed_pressure_pa: FloatArray

    if TYPE_CHECKING:  # defined by each subclass: values (M,) at shapes (M,) of panels index (M,)
        def __init__(self, panels: Iterable[Any], quadrature_points: int = ...) -> None: ...

        def energy(self, shape: FloatArray, index: IntArray) -> FloatArray: ...

        def volume(self, shape: FloatArray, index: IntArray) -> FloatArray: ...

        def pressure(self, shape: FloatArray, index: IntArray) -> FloatArray: ...

    @staticmethod
    def _checked_panels(panels: Iterable[Any], kind: type[_PanelT]) -> list[_PanelT]:
        """Return the panels as a list; refuse none at all and any that is not a ``kind``."""
        panels = list(panels)
        if not panels:
            raise ValueError('an actuation model needs at least one panel')
        article = 'an' if kind.__name__[0] in 'AEIOU' else 'a'
        for index, panel in enumerate(panels):
            if not isinstance(panel, kind):
                raise TypeError(f'panel {index} is a {type(panel).__name__}, '
                                f'not {article} {kind.__name__}')
        return panels

    def __len__(self) -> int:
        return len(self.panels)

    @property
    def batch(self) -> Batch:
        return self.fold.batch

    def _shape_array(self, shape: npt.ArrayLike) -> FloatArray:
        return np.broadcast_to(real_array(self.shape_name, shape), (len(self),))

    def elastic_energy_j(self, shape: npt.ArrayLike) -> FloatArray:
        """Elastic energy stored in each panel at shape parameters ``shape`` [J]."""
        return self.energy(self._shape_array(shape), self._all)

    def cushion_volume_m3(self, shape: npt.ArrayLike) -> FloatArray:
        """Cushion volume at shape parameters ``shape`` [m3]."""
        return self.volume(self._shape_array(shape), self._all)

    def pressure_from_shape(self, shape: npt.ArrayLike) -> FloatArray:
        """Gauge pressure [Pa] that holds each panel at shape parameter ``shape``."""
        return self.pressure(self._shape_array(shape), self._all)

    def stiffness_at_shape(self, shape: npt.ArrayLike,
                           gauge_pressure_pa: FloatOrArray) -> FloatArray:
        """``U'' - p V''``, the stiffness of the one degree of freedom, the shape parameter.

        Second derivatives by central second differences of step ``stiffness_step``; in J per
        square unit of the shape parameter. Positive: the state is stable under the pressure.
        """
        shape = self._shape_array(shape)
        step = self.stiffness_step

        def second(function: _ShapeMap) -> FloatArray:
            return (function(shape + step, self._all) - 2 * function(shape, self._all)
                    + function(shape - step, self._all)) / step ** 2

        return second(self.energy) - gauge_pressure_pa * second(self.volume)

    def pressure_from_closure(self, closure: npt.ArrayLike) -> FloatArray:
        """Gauge pressure [Pa] that holds each panel at closure in [0, 1]."""
        return self.pressure_from_shape(self.fold.state_from_closure(closure).shape_parameter)

    def shape_from_pressure(self, gauge_pressure_pa: npt.ArrayLike) -> FloatArray:
        """Shape parameter reached at a gauge pressure [Pa], held at the open and closed stops.

        Below zero gauge the panel rests open on its back part; above the closed pressure it
        rests on its closed stop.
        """
        pressure = np.broadcast_to(real_array('gauge_pressure_pa', gauge_pressure_pa),
                                   (len(self),))
        target = np.clip(pressure, 0.0, self.closed_pressure_pa)
        opened, closed = self.fold.open_shape, self.fold.closed_shape
        result = find_root(lambda shape, goal, index: self.pressure(shape, index) - goal,
                           (opened, closed), args=(target, self._all),
                           tolerances={'xatol': 1e-14, 'xrtol': 1e-13})
        if not np.all(result.success):
            raise ArithmeticError('pressure inversion did not converge')
        shape = np.clip(result.x, opened, closed)
        shape = np.where(pressure <= 0.0, opened, shape)
        return np.where(pressure >= self.closed_pressure_pa, closed, shape)

    def closure_from_pressure(self, gauge_pressure_pa: npt.ArrayLike) -> FloatArray:
        """Closure in [0, 1] reached at a gauge pressure [Pa]."""
        return self.fold.state_from_shape(self.shape_from_pressure(gauge_pressure_pa)).closure

    def reachable_closure(self, supply_gauge_pa: float) -> FloatArray:
        """Closure reachable with a supply at ``supply_gauge_pa``; warns if short of closed."""
        supply = real_scalar('supply_gauge_pa', supply_gauge_pa)
        reachable = self.closure_from_pressure(supply)
        short = reachable < 1.0
        if np.any(short):
            index = int(np.flatnonzero(short)[0])
            warnings.warn(
                f'a {supply / 1e3:.2f} kPa supply reaches closure {reachable[index]:.3f} of '
                f'panel {index}; closing it needs {self.closed_pressure_pa[index] / 1e3:.2f} kPa',
                UnreachableClosureWarning, stacklevel=2)
        return reachable

    def shape_table(self, closures: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Shape parameters and apex fold angles [rad] (N, S) at closure samples (S,)."""
        states = [self.fold.state_from_closure(c) for c in closures]
        return (np.stack([state.shape_parameter for state in states], axis=1),
                np.stack([state.apex_fold_angle_rad for state in states], axis=1))
