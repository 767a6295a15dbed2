"""An open structural model of a thin GFRP sheet: membrane triangles and mid-edge bending.

:mod:`.elements` (membrane triangles, dihedral angles, cushion prisms), :mod:`.shell` (the
mid-edge bending energy), :mod:`.sheet` (a sheet, its energy and its equilibrium path under a
cushion, or with held coordinates). Verification figures: ``msg_docs/structure.md``.
"""

from flectofold_model.structure.sheet import (PathError, PathPoint, PrescribedEquilibrium,
                                              Sheet, SheetSystem, solve_prescribed,
                                              trace_path)

__all__ = ['PathError', 'PathPoint', 'PrescribedEquilibrium', 'Sheet', 'SheetSystem',
           'solve_prescribed', 'trace_path']
