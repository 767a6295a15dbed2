"""Shared test fixtures."""

import os
import signal

import pytest

# A suite started in the background of a non-interactive shell (``./run test &`` in a script)
# inherits SIGINT ignored, and an ignored signal stays ignored across exec: the stop tests'
# Ctrl-C would reach programs that ignore it, and the runner's tests would start from a state
# no terminal gives. Take SIGINT back as Python's own start-up installs it.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

# Every embedded facade exceeds the 0.7 % fatigue strain estimate at closure 1, so loading one
# warns (StrainLimitWarning, whose message starts "strain limit"). In this process pytest.ini
# filters it; the programs the suite starts inherit this filter, so that their stderr holds
# only what their tests check (the one line of a refusal, for one). test_strain_warning.py
# checks the warning itself.
os.environ['PYTHONWARNINGS'] = ','.join(
    filter(None, [os.environ.get('PYTHONWARNINGS'), 'ignore:strain limit']))

SMALL_FACADE = """
name: small
site: {{latitude_deg: 48.78, longitude_deg: 9.18, elevation_m: 245, utc_offset_h: 2}}
facade: {{azimuth_deg: 180}}
surface: {{type: saddle, width_m: 2.2, height_m: 2.2, curvature_u_per_m: -0.08,
          curvature_v_per_m: 0.08}}
grid: {{rows: 2, columns: 2, gap_m: 0.1, midrib_along: v}}
panel: {{fold_radius_m: 1.0, midrib_end_width_m: 0.04, hinge_width_m: 0.03}}
control: {{{control}}}
"""


@pytest.fixture(scope='session')
def small_facade_text():
    """YAML of a 2 x 2 south-facing saddle facade with the given ``control`` mapping body."""
    return lambda control: SMALL_FACADE.format(control=control)


@pytest.fixture(autouse=True, scope='session')
def compiled_kernels(request):
    """Compile the simulation's kernels once, before any test starts a panel process.

    After a change to the model the first process that runs them compiles for tens of seconds
    (``flectofold_model._compiled``); a panel node started by a test would spend its start-up
    wait on that. Loading them from the cache takes under a second.
    """
    if any(item.get_closest_marker('graph') for item in request.session.items):
        from flectofold_model.control import compile_kernels
        compile_kernels()
