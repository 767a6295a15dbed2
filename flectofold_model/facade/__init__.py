"""Facades: validated YAML descriptions, the surfaces they tessellate, the embedded demonstrator.

- :mod:`.description`: YAML in, validated panels with frames and pre-folds out
  (:func:`load_facade`, :class:`Facade`);
- :mod:`.surfaces`: plane, cylinder, dome, saddle and OBJ quad meshes, and their patches;
- ``data/``: the embedded 6 x 6 demonstrator (:data:`DEFAULT_FACADE`).
"""

from flectofold_model.facade.description import (build_facade, DEFAULT_FACADE, Facade, FacadeError,
                                                 load_facade)

__all__ = ['DEFAULT_FACADE', 'Facade', 'FacadeError', 'build_facade', 'load_facade']
