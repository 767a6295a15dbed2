"""How the model's compiled kernels are compiled: one decorator for all of them.

numba [1] compiles them on first use and caches the machine code on disk. Its cache checks
only the source file of the function it holds, not the kernels and constants that function
inlined from other modules: edit the integrator and a cached loop kernel would run the old
one. So the cache lives in a directory named after a digest of every source file of
``flectofold_model`` and numba's version: any change to the model compiles afresh.

``error_model='numpy'``: a division by zero gives inf or NaN as in numpy instead of raising;
without it every division carries a check that keeps the compiler from optimising the inner
loops (measured: the cushion table lookup 100 ns -> 23 ns). The kernels' inputs are validated
before they are called. The small functions of inner loops are inlined into their callers
(:data:`inline_kernel`), which spares the per-call reference counting of their array
arguments (measured: a Dormand-Prince step 2.2 us -> 0.8 us).

[1] numba, https://numba.pydata.org (``numba.njit``, "Cache Notes").
"""

import contextlib
import fcntl
import hashlib
import os
from pathlib import Path
import shutil
from typing import Iterator, Optional

import numba

_PACKAGE = Path(__file__).resolve().parent
_PREFIX = 'numba-'


def _digest() -> str:
    """Digest of numba's version and every source file of the package."""
    digest = hashlib.sha256(numba.__version__.encode())
    for path in sorted(_PACKAGE.rglob('*.py')):
        digest.update(path.relative_to(_PACKAGE).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def _cache_directory() -> Optional[str]:
    """Return a writable directory for this version's kernels; remove older versions'."""
    base = os.environ.get('NUMBA_CACHE_DIR')
    candidates = [Path(base)] if base else [
        _PACKAGE / '__pycache__', Path.home() / '.cache' / 'flectofold']
    name = _PREFIX + _digest()
    for parent in candidates:
        try:
            (parent / name).mkdir(parents=True, exist_ok=True)
        except OSError:
            continue
        if os.access(parent / name, os.W_OK):
            for old in parent.glob(_PREFIX + '*'):
                if old.name != name:
                    shutil.rmtree(old, ignore_errors=True)
            return str(parent / name)
    return None


_directory = _cache_directory()
if _directory is not None:
    # read by numba when a cached function is decorated, which happens after this line
    # numba.config sets its names from the environment at run time: the checker sees none
    numba.config.CACHE_DIR = _directory  # type: ignore[attr-defined]


@contextlib.contextmanager
def compile_lock() -> Iterator[None]:
    """Hold the cache's lock: processes that start together compile once, then load.

    The first holder compiles and writes the cache; the others wait and load it.
    """
    if _directory is None:
        yield
        return
    with open(os.path.join(_directory, '.lock'), 'a') as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


kernel = numba.njit(cache=True, error_model='numpy')
"""Decorator: compile a function in nopython mode, cached, with numpy's error model."""

inline_kernel = numba.njit(cache=True, error_model='numpy', inline='always')
""":data:`kernel` for the small functions of inner loops, inlined into their callers."""
