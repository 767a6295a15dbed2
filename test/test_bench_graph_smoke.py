"""The graph benchmark's CI smoke (``bench/bench_graph.py --quick``): it runs and measures.

A smoke, not a benchmark: behaviour only (every state published, every setpoint arrived,
a clean stop), no speed. The figures live in ``bench/results/graph.md``.
"""

import json
import math
from pathlib import Path
import subprocess
import sys

import pytest
from ros_graph import bench_domains

pytestmark = pytest.mark.graph
BENCH = Path(__file__).resolve().parents[1] / 'bench' / 'bench_graph.py'


def test_the_quick_graph_benchmark_runs_and_measures(tmp_path):
    result = subprocess.run([sys.executable, str(BENCH), '--quick', '--json',
                             str(tmp_path / 'graph.json'), '--domain', str(bench_domains())],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    report = json.loads((tmp_path / 'graph.json').read_text())
    rows = {row['phase']: row for row in report['rows']}
    assert set(rows) == {'rest', 'moving'}
    for row in rows.values():
        assert row['N'] == 36 and row['P'] == 1 and not row['error']
        assert all(abs(hz - 10.0) < 0.5 for hz in row['panel_states_hz'])
        assert math.isfinite(row['panel_cores']) and math.isfinite(row['peer_cores'])
        assert row['stop_s'] < 5.0
    assert rows['rest']['per_panel_hz'] == pytest.approx(1.0, abs=0.1)  # the heartbeat
    assert rows['moving']['setpoints_sent'] > 0 and rows['moving']['setpoints_lost'] == 0
    assert (tmp_path / 'graph.md').exists()
