"""The scheduler's air budget for a facade of hexagonal panels."""

from types import SimpleNamespace

import numpy as np
import pytest

from flectofold_model.actuation import (CushionMap, DEMONSTRATOR_PLANT, HEXAGON_ACTUATED,
                                        HexagonActuationModel, PneumaticPlant)
from flectofold_model.facade.description import load_facade
from flectofold_model.kinematics import HEXAGON_MODULE, HexagonPanel
from flectofold_model.scheduling.facade_schedule import full_close_air_nl, representative_panel

BIGGER = HexagonPanel(circumradius_m=0.66, fold_line_sag_m=0.06, hinge_width_m=0.03,
                      prefold_rad=HEXAGON_MODULE.prefold_rad)
#: A stand-in for a facade description: what the air budget and the table's panel read.
FACADE = SimpleNamespace(panels=[HEXAGON_MODULE, BIGGER, HEXAGON_MODULE], cushion_map='energy')


def test_full_close_air_of_hexagons_is_what_the_plant_fills():
    """Filling one module wide open to its closed stop takes the budget's free air."""
    air = full_close_air_nl(FACADE)
    assert air.shape == (3,) and air[0] == air[2]
    table = CushionMap(HexagonActuationModel([HEXAGON_ACTUATED]))
    plant = PneumaticPlant(DEMONSTRATOR_PLANT, table, 1, integrator='embedded')
    closed = table.pressure_pa[0, -1]
    while plant.gauge_pressure_pa[0] < closed:
        plant.step(0.01, 1.0, 0.0)
    filled = plant.free_air_used_m3[0] * 1e3
    # The last step overshoots the closed pressure by one step's worth of air, at most.
    assert air[0] == pytest.approx(filled, rel=0.02)


def test_the_embedded_hexagon_facade_has_an_air_budget_per_panel():
    facade = load_facade('hexagon_6x6')
    air = full_close_air_nl(facade)
    assert air.shape == (len(facade),)
    assert np.all((air > 15.0) & (air < 27.0))  # the plant fills 21 NL for one module


def test_the_table_is_built_for_the_median_hexagon_by_area():
    facade = SimpleNamespace(panels=[BIGGER, HEXAGON_MODULE, BIGGER], cushion_map='energy')
    assert representative_panel(facade) == BIGGER
    assert np.isclose(representative_panel(FACADE).area_m2, HEXAGON_MODULE.area_m2)
