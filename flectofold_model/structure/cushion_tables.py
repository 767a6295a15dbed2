"""The plant's cushion map from the structural model, computed once per panel design, cached.

The plant, the pressure loops and the scheduler see a panel only through its
:class:`~..actuation.cushion_map.CushionMap`: gauge pressure, cushion volume, compliance
``dV/dp`` and apex fold angle at closures evenly spaced from 0 to 1. :func:`structural_tables`
reads them off a quad panel's structural path (:func:`~.panel.structural_path`) instead of the
energy statics: the pressure and the air where the path's apex fold is the closure's, the
compliance as ``d(air)/dp`` along the path (central differences between its equilibria,
interpolated), the fold angle the closure's own. A path is about 15 s of CPU on
:data:`MAP_MESH`, so the tables are cached on disk per panel design, like the compiled
kernels: the key is a digest of the panel (geometry, laminates, cushion), the mesh, the
closures and every source file of :mod:`flectofold_model.structure`, so a change to any of
them computes afresh; callers that ask for one design at once trace it once (a lock per
entry).

Only a path that closes with its pressure rising all the way makes a map: a panel that does not
close in the structure (the hexagonal module, the 1000 mm radius variant) or that passes a
pressure maximum (a pressure regulator would snap it through) is refused with the reason.
The cushion is the structure's: the volume between the loaded footprint and the back plate
(``msg_docs/structure.md``), not the energy statics' strip cushion.
"""

import contextlib
import fcntl
import hashlib
import os
from pathlib import Path
from typing import Iterable, Iterator, Optional
import zipfile

import numpy as np

from flectofold_model._validate import FloatArray
from flectofold_model.actuation.cushion_map import CushionMap, distinct_panels
from flectofold_model.actuation.statics import ActuatedPanel
from flectofold_model.structure.comparison import closure_apex_folds_rad
from flectofold_model.structure.panel import (CONVERGED_MESH, PanelMesh, Progress,
                                              structural_path, StructuralPath)

_PACKAGE = Path(__file__).resolve().parent
#: Environment variable naming the cache directory (default ``~/.cache/flectofold/structure``).
CACHE_ENVIRONMENT = 'FLECTOFOLD_STRUCTURE_CACHE'
_FIELDS = ('pressure_pa', 'volume_m3', 'compliance_m3_per_pa', 'fold_angle_rad')
#: The mesh a map is traced on unless another is given: the one whose tip travel is converged
#: to 1 % (the default mesh's closing pressure is up to 14 % low; ``msg_docs/structure.md``).
MAP_MESH = CONVERGED_MESH


def cache_directory() -> Path:
    """Return the directory the structural tables are cached in (created when written)."""
    configured = os.environ.get(CACHE_ENVIRONMENT)
    return Path(configured) if configured else Path.home() / '.cache' / 'flectofold' / 'structure'


def cache_key(actuated: ActuatedPanel, mesh: PanelMesh, samples: int) -> str:
    """Digest of a panel design, its mesh, the closures and the structure's source files."""
    digest = hashlib.sha256(repr((actuated, mesh, samples)).encode())
    for path in sorted(_PACKAGE.glob('*.py')):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:24]


class NotCached(ValueError):
    """A structural map asked for without tracing (``trace=False``) is not in the cache."""


def structural_tables(actuated: ActuatedPanel, mesh: PanelMesh = MAP_MESH, samples: int = 129,
                      cache: bool = True, progress: Optional[Progress] = None,
                      trace: bool = True) -> tuple[FloatArray, ...]:
    """Pressure, volume, compliance and apex fold (S,) of a quad panel at ``samples`` closures.

    Parameters
    ----------
    actuated : ActuatedPanel
    mesh : PanelMesh
    samples : int
        Closures evenly spaced from 0 to 1, both included (at least 3).
    cache : bool
        Read the tables from the cache when there, write them there when computed.
    progress : callable, optional
        Passed to :func:`~.panel.structural_path` when the path is traced.
    trace : bool
        Trace the path when the cache does not have it; False raises :class:`NotCached`
        instead (a process that must start in seconds, not minutes).

    Returns
    -------
    tuple of ndarray
        Gauge pressure [Pa], cushion volume [m3], compliance ``dV/dp`` [m3/Pa] and apex fold
        angle [rad], each (S,).

    Raises
    ------
    ValueError
        When the path does not close or passes a pressure maximum (named in the message).
    NotCached
        With ``trace`` False, when the cache does not hold the tables.
    """
    if not isinstance(actuated, ActuatedPanel):
        raise TypeError(f'structural tables are built for quad panels (an ActuatedPanel), '
                        f'got {type(actuated).__name__}')
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 3:
        raise ValueError(f'samples must be an integer of at least 3, got {samples!r}')
    path_of_file = cache_directory() / f'{cache_key(actuated, mesh, samples)}.npz'
    if not cache and not trace:
        raise ValueError('structural tables need the cache or leave to trace the path')
    if not cache:
        return _from_path(actuated, structural_path(actuated, mesh, progress=progress),
                          samples)
    # Processes (or threads) that ask for one design together trace it once: the first
    # holds the entry's lock while it traces and writes, the others wait and read.
    with _entry_lock(path_of_file):
        cached = _read(path_of_file, samples)
        if cached is not None:
            return cached
        if not trace:
            raise NotCached(f'no structural cushion map of this panel design is cached (entry '
                            f'{path_of_file.name} in {path_of_file.parent})')
        tables = _from_path(actuated, structural_path(actuated, mesh, progress=progress),
                            samples)
        _write(path_of_file, tables)
    return tables


def structural_cushion_map(panels: Iterable[ActuatedPanel], mesh: PanelMesh = MAP_MESH,
                           samples: int = 129, cache: bool = True, trace: bool = True,
                           progress: Optional[Progress] = None) -> CushionMap:
    """Return the :class:`~..actuation.cushion_map.CushionMap` of quad panels from the structure.

    Panels of one design share one path (and one cache entry); ``cache``, ``trace`` and
    ``progress`` as for :func:`structural_tables`.
    """
    distinct, row = distinct_panels(list(panels))
    if not distinct:
        raise ValueError('a cushion map needs at least one panel')
    tables = [structural_tables(panel, mesh, samples, cache, progress, trace)
              for panel in distinct]
    return CushionMap.from_tables([np.stack(column) for column in zip(*tables)], row)


def _from_path(actuated: ActuatedPanel, path: StructuralPath,
               samples: int) -> tuple[FloatArray, ...]:
    if path.ended != 'closed':
        raise ValueError(f'the panel does not close in the structure ({path.ended}): no '
                         f'structural cushion map')
    if len(path.limit_points):
        index = int(path.limit_points[0])
        raise ValueError(f'the structural path passes a pressure maximum of '
                         f'{path.pressure_pa[index] / 1e3:.2f} kPa at '
                         f'{np.degrees(path.apex_fold_rad[index]):.1f} deg apex fold: a '
                         f'pressure regulator would snap the panel through, no cushion map')
    unstable = np.flatnonzero(~np.asarray(path.stable_at_pressure, dtype=bool))
    if len(unstable):
        index = int(unstable[0])
        raise ValueError(f'the structural path is not stable with the pressure held from '
                         f'{path.pressure_pa[index] / 1e3:.2f} kPa at '
                         f'{np.degrees(path.apex_fold_rad[index]):.1f} deg apex fold on (a '
                         f'bifurcation): no cushion map')
    fold = closure_apex_folds_rad(actuated, np.linspace(0.0, 1.0, samples))
    along = np.asarray(path.apex_fold_rad)
    if np.any(np.diff(along) <= 0) or np.any(np.diff(path.pressure_pa) <= 0):
        raise ValueError('the structural path does not fold and rise in pressure at every '
                         'step: no cushion map')
    # The open state is the moulded one: its apex fold is the pre-fold to the mould's
    # tolerance, so closure 0 is read at the path's first point.
    fold_at = np.clip(fold, along[0], along[-1])
    fold_at[0] = along[0]
    pressure = np.interp(fold_at, along, path.pressure_pa)
    volume = path.open_volume_m3 + np.interp(fold_at, along, path.air_m3)
    compliance = np.interp(fold_at, along, np.gradient(path.air_m3, path.pressure_pa))
    return pressure, volume, compliance, fold


@contextlib.contextmanager
def _entry_lock(path: Path) -> Iterator[None]:
    """Hold an exclusive lock on a cache entry; without a writable cache, no lock."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        lock = open(path.with_suffix('.lock'), 'a')
    except OSError:
        yield
        return
    with lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def _read(path: Path, samples: int) -> Optional[tuple[FloatArray, ...]]:
    """Return cached tables, or None when absent or not whole (then they are recomputed)."""
    try:
        with np.load(path) as data:
            tables = tuple(np.array(data[name], dtype=np.float64) for name in _FIELDS)
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile):
        return None
    if any(t.shape != (samples,) or not np.all(np.isfinite(t)) for t in tables):
        return None
    return tables


def _write(path: Path, tables: tuple[FloatArray, ...]) -> None:
    """Write the tables atomically: a reader never sees half a file.

    A cache that cannot be written is skipped; the tables are still returned.
    """
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = path.with_suffix(f'.{os.getpid()}.partial.npz')
        # numpy's stubs match the keyword arrays against allow_pickle too
        np.savez(partial, **dict(zip(_FIELDS, tables)))  # type: ignore[arg-type]
        os.replace(partial, path)
    except OSError:
        pass
