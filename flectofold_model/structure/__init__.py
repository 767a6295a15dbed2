"""An open structural model of a thin GFRP sheet and of the panels made of one.

:mod:`.elements` (membrane triangles, dihedral angles, cushion prisms), :mod:`.shell` (the
mid-edge bending energy), :mod:`.sheet` (a sheet, its energy and its equilibrium path under a
cushion, or with held coordinates), :mod:`.panel` (a quad panel meshed with its hinge bands,
its moulded pre-fold, supports and cushion, and its path from open toward closed),
:mod:`.symmetry` (a mirror-symmetric sheet's path on one symmetry cell, its stability from
every symmetry class), :mod:`.hexagon` (the same for a hexagonal panel), :mod:`.comparison`
(the path beside the reflection model at the same closures), :mod:`.cushion_tables` (the
plant's cushion map from the structure, cached per design), :mod:`.facade_map` (a facade's
map as its description chooses: energy statics or the structure of its median panel).
Verification and comparison figures: ``msg_docs/structure.md``.
"""

from flectofold_model.structure.cushion_tables import structural_cushion_map, structural_tables
from flectofold_model.structure.hexagon import (HEXAGON_CONVERGED_MESH,
                                                HEXAGON_REFERENCE_MESH,
                                                hexagon_structural_path, HexagonMesh,
                                                HexagonSheet)
from flectofold_model.structure.panel import (PanelMesh, PanelSheet, structural_path,
                                              StructuralPath)
from flectofold_model.structure.sheet import (PathError, PathPoint, PrescribedEquilibrium,
                                              Sheet, SheetSystem, solve_prescribed,
                                              trace_path)
from flectofold_model.structure.symmetry import Mirror, MirroredSystem

__all__ = ['HEXAGON_CONVERGED_MESH', 'HEXAGON_REFERENCE_MESH', 'HexagonMesh', 'HexagonSheet',
           'Mirror', 'MirroredSystem', 'PanelMesh',
           'PanelSheet', 'PathError', 'PathPoint', 'PrescribedEquilibrium', 'Sheet',
           'SheetSystem', 'StructuralPath',
           'hexagon_structural_path', 'solve_prescribed', 'structural_cushion_map',
           'structural_path', 'structural_tables', 'trace_path']
