"""Fixtures of the Modbus tests."""

import pytest

from flectofold_model.actuation import actuated_like, actuation_model_of, CushionMap
from flectofold_model.facade import load_facade


@pytest.fixture(scope='module')
def model():
    """Return the first two demonstrator panels' actuation and cushion map (a terminal's)."""
    facade = load_facade()
    actuation = actuation_model_of(actuated_like(facade.panels[i]) for i in range(2))
    return actuation, CushionMap(actuation)
