"""What ``setup.py`` hands setuptools, found by running it with ``setup()`` replaced."""

import contextlib
from pathlib import Path
import runpy
from unittest import mock

import setuptools

ROOT = Path(__file__).resolve().parents[2]


def setup_arguments():
    """Return the keyword arguments ``setup.py`` passes to ``setuptools.setup``."""
    calls = []
    with contextlib.chdir(ROOT), mock.patch.object(setuptools, 'setup',
                                                   lambda **kwargs: calls.append(kwargs)):
        runpy.run_path(str(ROOT / 'setup.py'), run_name='__main__')
    (arguments,) = calls
    return arguments


def console_scripts():
    """Return ``{name: 'module:function'}`` of the console scripts ``setup.py`` declares."""
    return dict(line.split(' = ') for line in setup_arguments()['entry_points']['console_scripts'])
