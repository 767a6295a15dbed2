"""A panel process of more than 50 panels reports them in slices, each panel once a period.

``msg_docs/panel_node.md``: ``/diagnostics`` carries one status per panel every
``diagnostics_period_s``, in one message up to 50 panels and in slices of 50 spread over the
period for more (1,000 statuses built in one go held a process's tick up by 46 ms), and one
status for the process with the first slice.
"""

from collections import Counter
from pathlib import Path
import time

import pytest
from ros_graph import domain_for, Graph
import yaml

from flectofold_model.facade import load_facade
from flectofold_ros.nodes.panel import STATUSES_PER_MESSAGE
from flectofold_ros.runtime.interfaces import subscription
from flectofold_ros.wire import contract

pytestmark = pytest.mark.graph
DEMONSTRATOR_YAML = (Path(__file__).resolve().parents[3] / 'flectofold_model' / 'facade' /
                     'data' / 'demonstrator_6x6.yaml')
ROWS, COLUMNS = 8, 8  # 64 panels: two slices
PERIODS = 3


@pytest.fixture()
def plane_facade(tmp_path):
    description = yaml.safe_load(DEMONSTRATOR_YAML.read_text())
    description['name'] = 'plane-8x8'
    description['surface'] = {'type': 'plane', 'width_m': 8.8, 'height_m': 8.8}
    description['grid'].update(rows=ROWS, columns=COLUMNS)
    path = tmp_path / 'plane.yaml'
    path.write_text(yaml.safe_dump(description, sort_keys=False))
    return path


def test_every_panel_is_reported_once_a_period_in_slices(plane_facade):
    ids = load_facade(str(plane_facade)).panel_ids
    assert len(ids) > STATUSES_PER_MESSAGE
    graph = Graph(domain_for(33))
    messages = []  # (arrival, hardware ids of the message's statuses)
    slices = -(-len(ids) // STATUSES_PER_MESSAGE)  # messages a period
    try:
        process = graph.start('panel_group', '--group', '0/1', '--facade', str(plane_facade))
        subscription(graph.node, contract.DIAGNOSTICS, lambda message: messages.append(
            (time.monotonic(), [status.hardware_id for status in message.status])))
        assert graph.spin_until(lambda: any('panel_group_0' in ids_ for _, ids_ in messages),
                                60.0), graph.stop(process)[1]
        first = next(i for i, (_, ids_) in enumerate(messages) if 'panel_group_0' in ids_)
        # whole periods from the first process status, whenever they arrive
        assert graph.spin_until(lambda: len(messages) >= first + PERIODS * slices, 60.0), \
            (len(messages), first)
        code, output = graph.stop(process)
    finally:
        graph.close()
    assert code == 0, output
    window = [ids_ for _, ids_ in messages[first:first + PERIODS * slices]]
    # each period starts with the first slice, which carries the process status
    assert ['panel_group_0' in ids_ for ids_ in window] == [True, *[False] * (slices - 1)] * \
        PERIODS, window
    assert max(len(ids_) for ids_ in window) <= STATUSES_PER_MESSAGE + 1
    counts = Counter(hardware_id for ids_ in window for hardware_id in ids_)
    assert counts['panel_group_0'] == PERIODS
    assert {counts[panel_id] for panel_id in ids} == {PERIODS}, counts
