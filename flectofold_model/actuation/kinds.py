"""Actuated panels of both kinds behind one interface: quad and hexagonal panels.

:func:`actuated_like` gives a panel geometry of either kind the build (laminates, cushion) of
its kind's preset or of a template; :func:`actuation_model_of` builds the static model of
actuated panels of one kind. Both models share the surface of
:class:`~.static_model.StaticActuationModel`, so a :class:`~.cushion_map.CushionMap`, the
plant and the loops work on either.
"""

from typing import Iterable, Optional, Union

from flectofold_model.actuation.hexagon_statics import (hexagon_actuated_like,
                                                        HexagonActuatedPanel,
                                                        HexagonActuationModel)
from flectofold_model.actuation.static_model import StaticActuationModel
from flectofold_model.actuation.statics import actuated_like as quad_actuated_like
from flectofold_model.actuation.statics import ActuatedPanel, ActuationModel
from flectofold_model.kinematics.hexagon_panel import HexagonPanel
from flectofold_model.kinematics.kinds import Panel
from flectofold_model.kinematics.panel import PanelGeometry

#: An actuated panel of either kind.
AnyActuatedPanel = Union[ActuatedPanel, HexagonActuatedPanel]
#: Actuated panel class -> its static model class.
MODELS: dict[type, type[StaticActuationModel]] = {
    ActuatedPanel: ActuationModel, HexagonActuatedPanel: HexagonActuationModel}


def actuated_like(geometry: Panel,
                  template: Optional[AnyActuatedPanel] = None) -> AnyActuatedPanel:
    """Build the actuated panel of ``geometry`` (quad or hexagonal) like ``template``.

    ``template`` defaults to the kind's preset (``DEMONSTRATOR_ACTUATED`` for a
    :class:`~flectofold_model.kinematics.panel.PanelGeometry`, ``HEXAGON_ACTUATED`` for a
    :class:`~flectofold_model.kinematics.hexagon_panel.HexagonPanel`); a template must be of
    the geometry's kind.
    """
    if isinstance(geometry, HexagonPanel):
        return hexagon_actuated_like(geometry, template)
    if isinstance(geometry, PanelGeometry):
        if template is not None and not isinstance(template, ActuatedPanel):
            raise TypeError(f'template must be an ActuatedPanel for a quad panel, got '
                            f'{type(template).__name__}')
        return quad_actuated_like(geometry, template)
    raise TypeError(f'{type(geometry).__name__} is not a panel geometry of a known kind '
                    f'(PanelGeometry, HexagonPanel)')


def actuation_model_of(actuated_panels: Iterable[AnyActuatedPanel],
                       quadrature_points: Optional[int] = None) -> StaticActuationModel:
    """Build the static model of actuated panels of one kind (an iterable, at least one).

    Mixed kinds raise ``ValueError``; ``quadrature_points`` defaults to the model's own.
    """
    panels = list(actuated_panels)
    if not panels:
        raise ValueError('an actuation model needs at least one panel')
    kinds = {type(panel) for panel in panels}
    unknown = [kind.__name__ for kind in kinds if kind not in MODELS]
    if unknown:
        raise TypeError(f'{", ".join(sorted(unknown))} is not an actuated panel '
                        f'(ActuatedPanel, HexagonActuatedPanel)')
    if len(kinds) > 1:
        raise ValueError('actuated panels of different kinds cannot share one actuation model; '
                         'split them by kind')
    model = MODELS[kinds.pop()]
    if quadrature_points is None:
        return model(panels)
    return model(panels, quadrature_points=quadrature_points)
