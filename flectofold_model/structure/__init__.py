"""An open structural model of a thin GFRP sheet and of the quad panel made of one.

:mod:`.elements` (membrane triangles, dihedral angles, cushion prisms), :mod:`.shell` (the
mid-edge bending energy), :mod:`.sheet` (a sheet, its energy and its equilibrium path under a
cushion, or with held coordinates), :mod:`.panel` (a quad panel meshed with its hinge bands,
its moulded pre-fold, supports and cushion, and its path from open toward closed),
:mod:`.comparison` (the path beside the reflection model at the same closures). Verification
and comparison figures: ``msg_docs/structure.md``.
"""

from flectofold_model.structure.panel import (PanelMesh, PanelSheet, structural_path,
                                              StructuralPath)
from flectofold_model.structure.sheet import (PathError, PathPoint, PrescribedEquilibrium,
                                              Sheet, SheetSystem, solve_prescribed,
                                              trace_path)

__all__ = ['PanelMesh', 'PanelSheet', 'PathError', 'PathPoint', 'PrescribedEquilibrium',
           'Sheet', 'SheetSystem', 'StructuralPath', 'solve_prescribed', 'structural_path',
           'trace_path']
