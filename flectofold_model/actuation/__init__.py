"""Actuation of a panel: laminates and cushion, the static pressure map, the pneumatic plant.

- :mod:`.laminate`, :mod:`.cushion`: the GFRP zones and the strip cushion;
- :mod:`.statics`: cushion pressure <-> closure by an energy model (:class:`ActuationModel`),
  and the panel presets;
- :mod:`.round_cushion`, :mod:`.hexagon_statics`: the same for hexagonal panels
  (:class:`HexagonActuationModel`, preset :data:`HEXAGON_ACTUATED`);
- :mod:`.static_model`: the maps both models share; :mod:`.kinds`: :func:`actuated_like` and
  :func:`actuation_model_of` for panels of either kind;
- :mod:`.cushion_map`: that map as a table for the plant and the loop (:class:`CushionMap`);
- :mod:`.flow`: ISO 6358 valve flow and the reference atmosphere;
- :mod:`.circuit`: supply, valves, relief, tubing and sensor of a circuit
  (:class:`PlantParameters`);
- :mod:`.plant`: the cushions in continuous time (:class:`PneumaticPlant`), with its
  :mod:`.stepping`, :mod:`.sensors` and injected :mod:`.faults`;
- :mod:`.analysis`: fill times and the holding pressure of a circuit.
"""

from flectofold_model.actuation.analysis import physical_fill_time_s
from flectofold_model.actuation.circuit import DEMONSTRATOR_PLANT, PlantParameters
from flectofold_model.actuation.cushion import StripCushion
from flectofold_model.actuation.cushion_map import CushionMap
from flectofold_model.actuation.flow import (AIR_GAS_CONSTANT, ATMOSPHERIC_PRESSURE_PA,
                                             conductance_from_catalogue, iso6358_mass_flow)
from flectofold_model.actuation.hexagon_statics import (HEXAGON_ACTUATED, HexagonActuatedPanel,
                                                        HexagonActuationModel)
from flectofold_model.actuation.kinds import actuated_like, actuation_model_of
from flectofold_model.actuation.laminate import Laminate
from flectofold_model.actuation.plant import PneumaticPlant
from flectofold_model.actuation.round_cushion import RoundCushion
from flectofold_model.actuation.static_model import StaticActuationModel
from flectofold_model.actuation.statics import (ActuatedPanel, ActuationModel,
                                                DEMONSTRATOR_ACTUATED, FLECTOLINE_ACTUATED,
                                                radius_study, UnreachableClosureWarning,
                                                WindResponse)

__all__ = [
    'AIR_GAS_CONSTANT', 'ATMOSPHERIC_PRESSURE_PA', 'ActuatedPanel', 'ActuationModel', 'CushionMap',
    'DEMONSTRATOR_ACTUATED', 'DEMONSTRATOR_PLANT', 'FLECTOLINE_ACTUATED', 'HEXAGON_ACTUATED',
    'HexagonActuatedPanel', 'HexagonActuationModel', 'Laminate', 'PlantParameters',
    'PneumaticPlant', 'RoundCushion', 'StaticActuationModel', 'StripCushion',
    'UnreachableClosureWarning', 'WindResponse', 'actuated_like', 'actuation_model_of',
    'conductance_from_catalogue', 'iso6358_mass_flow', 'physical_fill_time_s', 'radius_study',
]
