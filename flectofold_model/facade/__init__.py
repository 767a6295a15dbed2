"""Facades: validated YAML descriptions, the surfaces they tessellate, the embedded examples.

- :mod:`.description`: YAML in, validated panels with frames and pre-folds out
  (:func:`load_facade`, :class:`Facade`);
- :mod:`.surfaces`: plane, cylinder, dome, saddle and OBJ quad meshes, and their patches;
- :mod:`.hexagon_cells`, :mod:`.hexagon_prefold`, :mod:`.hexagon_description`: hexagonal
  facades (``panel: {type: hexagon}``): the lattice, the pre-fold rule, the panels;
- ``data/``: the embedded 6 x 6 quad demonstrator (:data:`DEFAULT_FACADE`) and its hexagonal
  counterpart ``hexagon_6x6``, each loadable by name (:func:`embedded_facades`).
"""

from flectofold_model.facade.description import (build_facade, DEFAULT_FACADE, embedded_facades,
                                                 Facade, facade_path, FacadeError, load_facade)

__all__ = ['DEFAULT_FACADE', 'Facade', 'FacadeError', 'build_facade', 'embedded_facades',
           'facade_path', 'load_facade']
