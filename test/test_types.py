"""The typed public API type-checks: mypy over the files ``mypy.ini`` names.

Every package of the model (``flectofold_model``) and the wire layer (``flectofold_ros/wire``):
every function annotated (``mypy.ini`` makes a missing annotation an error there) and every
annotation consistent with the code.
"""

from pathlib import Path
import subprocess
import sys
import time

ROOT = Path(__file__).resolve().parents[1]


def mypy_cache_dir(request, tmp_path_factory):
    """Return mypy's cache folder: kept by pytest between runs (git ignores it), else fresh.

    A first run reads numpy's stubs and takes some 10 to 30 s; with the cache, about a second.
    """
    cache = getattr(request.config, 'cache', None)  # None with -p no:cacheprovider
    if cache is None:
        return tmp_path_factory.mktemp('mypy_cache')
    return cache.mkdir('mypy')


def test_the_wire_layer_and_the_model_api_type_check(request, tmp_path_factory):
    started = time.perf_counter()
    check = subprocess.run(
        [sys.executable, '-m', 'mypy', '--config-file', str(ROOT / 'mypy.ini'),
         '--cache-dir', str(mypy_cache_dir(request, tmp_path_factory))],
        cwd=ROOT, capture_output=True, text=True, timeout=600)
    elapsed = time.perf_counter() - started
    assert check.returncode == 0, (f'mypy failed ({elapsed:.1f} s):\n'
                                   f'{check.stdout}{check.stderr}')
    assert 'Success: no issues found' in check.stdout, check.stdout
