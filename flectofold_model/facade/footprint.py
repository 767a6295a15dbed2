"""Each panel's footprint on its facade, and the facade's representative (median) panel.

What is computed once for a whole facade (the shading table, the structural cushion map) is
computed for its median panel by footprint area: the panels of one facade differ by
millimetres.
"""

import numpy as np

from flectofold_model._validate import FloatArray
from flectofold_model.facade.description import Facade
from flectofold_model.kinematics.hexagon_panel import HexagonPanel
from flectofold_model.kinematics.kinds import Panel


def footprint_areas_m2(facade: Facade) -> FloatArray:
    """Footprint area (N,) of each panel [m2]: a hexagon's own, a quad's length x width."""
    return np.array([panel.area_m2 if isinstance(panel, HexagonPanel)
                     else panel.length_m * panel.width_m for panel in facade.panels])


def footprint_weights(facade: Facade) -> FloatArray:
    """Each panel's share (N,) of the facade's footprint, summing to 1 [-]."""
    areas = footprint_areas_m2(facade)
    return areas / areas.sum()


def representative_index(facade: Facade) -> int:
    """Position of the facade's median panel by footprint area."""
    areas = footprint_areas_m2(facade)
    return int(np.argsort(areas)[len(areas) // 2])


def representative_panel(facade: Facade) -> Panel:
    """Pick the facade's median panel by footprint area (its geometry)."""
    return facade.panels[representative_index(facade)]
