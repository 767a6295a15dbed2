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
from ros_graph import bench_domains, PROMPT_S

pytestmark = pytest.mark.graph
BENCH = Path(__file__).resolve().parents[1] / 'bench' / 'bench_graph.py'
#: Rates are arrival rates over a window of wall time: a machine busy with other work delays
#: ticks and deliveries, so they are checked to +-20 % (10 Hz, not 5 or 20: every state sent).
RATE_TOLERANCE = 0.2


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
        assert all(hz == pytest.approx(10.0, rel=RATE_TOLERANCE)
                   for hz in row['panel_states_hz']), row['panel_states_hz']
        assert math.isfinite(row['panel_cores']) and math.isfinite(row['peer_cores'])
        assert row['stop_s'] < PROMPT_S, row['stop_s']
    # the heartbeat
    assert rows['rest']['per_panel_hz'] == pytest.approx(1.0, rel=RATE_TOLERANCE)
    assert rows['moving']['setpoints_sent'] > 0 and rows['moving']['setpoints_lost'] == 0
    assert (tmp_path / 'graph.md').exists()
