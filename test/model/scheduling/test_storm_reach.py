"""How long a panel takes to reach the storm position: the documented vent time holds."""

import numpy as np
import pytest

from flectofold_model.control.panel_loops import facade_loops
from flectofold_model.control.pressure_loop import ControllerParameters
from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_model.facade.description import build_facade
from flectofold_model.scheduling.facade_schedule import scheduler_parameters

#: msg_docs/coordinator_node.md: every panel is within REACHED of the storm position this
#: long after its storm setpoint, from fully closed (the longest move) [s].
STORM_REACH_S = 30.0
REACHED = 0.02
#: The panel node's defaults (msg_docs/panel_node.md): 0.1 s loop, 60 Pa hold band.
PANEL = {'control_period_s': 0.1, 'parameters': ControllerParameters(hold_band_pa=60.0)}


def reach_time_s(facade, panel_ids):
    """Simulate closed -> storm position; the time the last panel comes within REACHED [s]."""
    storm_position = scheduler_parameters(facade).storm_position
    loops = facade_loops(facade, panel_ids, **PANEL)
    loops.set_setpoints(np.ones(len(panel_ids)))
    loops.advance_to(0.0)
    loops.advance_to(60.0)
    assert np.all(loops.closure > 0.99)  # closed: the worst case
    loops.set_setpoints(np.full(len(panel_ids), storm_position))
    for step in range(1, 601):
        loops.advance_to(60.0 + 0.1 * step)
        if np.all(np.abs(loops.closure - storm_position) < REACHED):
            return 0.1 * step
    return np.inf


@pytest.mark.parametrize('which', ['demonstrator', 'small'])
def test_a_closed_panel_vents_to_the_storm_position_within_the_documented_time(
        which, small_facade_text):
    facade = (load_facade(DEFAULT_FACADE) if which == 'demonstrator'
              else build_facade(small_facade_text('period_s: 60.0')))
    ids = facade.panel_ids[:: max(1, len(facade) // 4)]
    reach_s = reach_time_s(facade, ids)
    print(f'{which}: closed -> storm position within {REACHED} in {reach_s:.1f} s')
    assert 10.0 < reach_s <= STORM_REACH_S  # a vent, not a jump; and within the bound
