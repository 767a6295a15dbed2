"""A hostile facade description given to the executables: exit 2, one line, no traceback."""

import os
from pathlib import Path
import resource
import subprocess
import sys

import pytest
from ros_graph import BIN, domain_for

sys.path.insert(0, str(Path(__file__).parents[2] / 'model' / 'facade'))
from test_hostile_yaml import BOMBS  # noqa: E402 - the same documents as the model's tests

pytestmark = pytest.mark.graph
#: Address space of each executable [bytes]: the expanded document would need far more.
ADDRESS_SPACE = 3 * 2**30


def commands(path, tmp_path):
    """Every way a user hands a facade description to the package."""
    return {
        'facade': ['--facade', str(path), '--rerun', 'none', '--out', str(tmp_path / 'out')],
        'day_report': ['--facade', str(path), '--out', str(tmp_path / 'out')],
        'coordinator_node': ['--ros-args', '-p', f'facade_file:={path}'],
        'rerun_bridge': ['--ros-args', '-p', 'viewer:=none', '-p',
                         f'rrd_path:={tmp_path / "x.rrd"}', '-p', f'facade_file:={path}'],
        'replay': [str(tmp_path / 'no_bag'), '--to-rrd', str(tmp_path / 'y.rrd'),
                   '--facade', str(path)],
    }


def limit_memory():
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE, ADDRESS_SPACE))


#: Every executable with the bomb under a known key; the other documents to two of them.
NAMES = ('facade', 'day_report', 'coordinator_node', 'rerun_bridge', 'replay')
CASES = [(name, 'known key') for name in NAMES]
CASES += [(name, document) for name in ('facade', 'coordinator_node')
          for document in ('unknown key', 'huge')]


@pytest.mark.parametrize('name, document', CASES)
def test_a_hostile_description_is_one_line_and_exit_2(name, document, tmp_path):
    path = tmp_path / 'hostile.yaml'
    path.write_text(BOMBS[document] if document in BOMBS else 'name: ' + 'x' * 50_000_000)
    environment = dict(os.environ, ROS_DOMAIN_ID=str(domain_for(47)), OPENBLAS_NUM_THREADS='1')
    run = subprocess.run([str(BIN / name), *commands(path, tmp_path)[name]], text=True,
                         capture_output=True, timeout=60, env=environment,
                         preexec_fn=limit_memory)
    lines = run.stderr.splitlines()
    assert run.returncode == 2, run.stderr[-3000:]
    assert len(lines) == 1 and lines[0].startswith(f'{name}: {path}: '), run.stderr[-3000:]
    reason = 'longer than' if document == 'huge' else 'YAML aliases (*name) are not accepted'
    assert reason in lines[0] and len(lines[0]) < 400
    assert 'Traceback' not in run.stdout + run.stderr


#: Loads as geometry, but the preset's cushion (0.28 m flat) is wider than these panels'
#: mid-rib (0.06 m at the end): before, the coordinator died with a [FATAL] traceback 29 s
#: into a bringup, naming no file.
UNACTUATED = """
name: unactuated
site: {latitude_deg: 48.78, longitude_deg: 9.18, elevation_m: 245, utc_offset_h: 2}
facade: {azimuth_deg: 180}
surface: {type: plane, width_m: 2.2, height_m: 2.2}
grid: {rows: 2, columns: 2, gap_m: 0.1, midrib_along: v}
panel: {fold_radius_m: 5.0, midrib_end_width_m: 0.01, hinge_width_m: 0.03}
"""


@pytest.mark.parametrize('name', ['facade', 'coordinator_node', 'panel_group'])
def test_a_facade_whose_panels_cannot_be_actuated_is_refused_before_anything_runs(
        name, tmp_path):
    path = tmp_path / 'unactuated.yaml'
    path.write_text(UNACTUATED)
    arguments = commands(path, tmp_path)
    arguments['panel_group'] = ['--group', '0/1', '--facade', str(path)]
    environment = dict(os.environ, ROS_DOMAIN_ID=str(domain_for(47)))
    run = subprocess.run([str(BIN / name), *arguments[name]], text=True, capture_output=True,
                         timeout=60, env=environment)
    lines = run.stderr.splitlines()
    assert run.returncode == 2 and len(lines) == 1, run.stderr[-3000:]
    assert lines[0] == (f'{name}: {path}: panel r00c00 cannot be actuated like the quad preset '
                        f'module: cushion flat_width_m=0.28 m is wider than the mid-rib '
                        f'(0.0601256 m)'), lines[0]
    assert 'ready' not in run.stdout
