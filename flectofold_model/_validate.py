"""Input checks shared by the public functions of ``flectofold_model``.

Every public function converts its inputs with these helpers, so bad input fails at the
boundary with a message that names the value and the reason.
"""

from dataclasses import fields
from numbers import Real
import os
from typing import Any, TypeVar, Union

import numpy as np
import numpy.typing as npt

#: A float64 array: what the model's vectorised functions return, one value per panel, time
#: or vertex.
FloatArray = npt.NDArray[np.float64]
#: A float or an array of floats (of any precision): a value that broadcasts against the
#: per-panel arrays.
FloatOrArray = Union[float, npt.NDArray[np.floating[Any]]]
#: A boolean array: a mask over panels, times or sensors.
BoolArray = npt.NDArray[np.bool_]
#: An integer array: indices of panels, vertices or faces.
IntArray = npt.NDArray[np.integer[Any]]
#: A file's path: text or a path object.
PathLike = Union[str, os.PathLike[str]]

_ArrayT = TypeVar('_ArrayT', bound=npt.NDArray[Any])


def real_array(name: str, value: npt.ArrayLike) -> FloatArray:
    """Return ``value`` as a float64 array; refuse non-numbers, NaN and infinity."""
    if isinstance(value, (bool, np.bool_)) or isinstance(value, (str, bytes)):
        raise TypeError(f'{name} must be a real number or an array of them, got {value!r}')
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise TypeError(
            f'{name} must be a real number or an array of them, got {value!r}') from error
    if array.dtype.kind != 'f':
        raise TypeError(f'{name} must be real, got dtype {array.dtype}')
    if not np.all(np.isfinite(array)):
        raise ValueError(f'{name} must be finite, got {_first_bad(array, ~np.isfinite(array))}')
    return array


def real_scalar(name: str, value: object) -> float:
    """Return ``value`` as a float; refuse non-numbers, booleans, NaN and infinity."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, Real):
        raise TypeError(f'{name} must be a real number, got {value!r}')
    number = float(value)
    if not np.isfinite(number):
        raise ValueError(f'{name} must be finite, got {number}')
    return number


def real_fields(instance: Any) -> None:
    """Replace every field of a frozen dataclass by its checked float (see real_scalar)."""
    for field in fields(instance):
        object.__setattr__(instance, field.name,
                           real_scalar(field.name, getattr(instance, field.name)))


def in_range(name: str, array: _ArrayT, low: float, high: float, unit: str = '',
             low_open: bool = False, high_open: bool = False) -> _ArrayT:
    """Check ``low <= array <= high`` (or strict where asked) and return ``array``."""
    below = array <= low if low_open else array < low
    above = array >= high if high_open else array > high
    bad = below | above
    if np.any(bad):
        left = '(' if low_open else '['
        right = ')' if high_open else ']'
        raise ValueError(
            f'{name} must lie in {left}{low:g}, {high:g}{right}{unit}, '
            f'got {_first_bad(array, bad)}{unit}')
    return array


def _first_bad(array: npt.NDArray[Any], bad: npt.ArrayLike) -> str:
    flat = np.flatnonzero(np.broadcast_to(bad, array.shape))
    if array.ndim == 0:
        return f'{float(array):g}'
    index = np.unravel_index(flat[0], array.shape)
    return f'{float(array[index]):g} at index {tuple(int(i) for i in index)}'


def panel_mask(panels: npt.ArrayLike, count: int) -> BoolArray:
    """Turn a boolean mask (N,) or an array of panel indices into a boolean ``(N,)`` mask."""
    if isinstance(panels, (str, bytes)):
        raise TypeError(f'panels must be a boolean mask or panel indices, got {panels!r}')
    selection = np.asarray(panels)
    if selection.dtype == np.bool_:
        if selection.shape != (count,):
            raise ValueError(f'a panel mask must have shape ({count},), '
                             f'got shape {selection.shape}')
        return selection.copy()
    if selection.size == 0:
        return np.zeros(count, dtype=bool)
    if selection.dtype.kind not in 'iu':
        raise TypeError(f'panels must be a boolean mask or panel indices, got {panels!r}')
    selection = selection.reshape(-1)
    if np.any(selection < 0) or np.any(selection >= count):
        raise ValueError(f'panel indices must lie in [0, {count - 1}], got {panels!r}')
    mask = np.zeros(count, dtype=bool)
    mask[selection] = True
    return mask
