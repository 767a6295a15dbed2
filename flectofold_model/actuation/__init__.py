"""Actuation of a panel: laminates and cushion, the static pressure map, the pneumatic plant.

- :mod:`.laminate`, :mod:`.cushion`: the GFRP zones and the strip cushion;
- :mod:`.statics`: cushion pressure <-> closure by an energy model (:class:`ActuationModel`),
  and the panel presets;
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
from flectofold_model.actuation.laminate import Laminate
from flectofold_model.actuation.plant import PneumaticPlant
from flectofold_model.actuation.statics import (actuated_like, ActuatedPanel, ActuationModel,
                                                DEMONSTRATOR_ACTUATED, FLECTOLINE_ACTUATED,
                                                radius_study, UnreachableClosureWarning,
                                                WindResponse)

__all__ = [
    'AIR_GAS_CONSTANT', 'ATMOSPHERIC_PRESSURE_PA', 'ActuatedPanel', 'ActuationModel', 'CushionMap',
    'DEMONSTRATOR_ACTUATED', 'DEMONSTRATOR_PLANT', 'FLECTOLINE_ACTUATED', 'Laminate',
    'PlantParameters', 'PneumaticPlant', 'StripCushion', 'UnreachableClosureWarning',
    'WindResponse', 'actuated_like', 'conductance_from_catalogue', 'iso6358_mass_flow',
    'physical_fill_time_s', 'radius_study',
]
