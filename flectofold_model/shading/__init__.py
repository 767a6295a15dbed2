"""Direct-sun shading and view of folded panels.

- :mod:`.ray_casting`: blocked and view fractions by ray casting against the folded meshes,
  and the rule that picks a closure from them;
- :mod:`.scan_lines`: the lines across a footprint along which they are measured exactly;
- :mod:`.table`: one panel type's blocked fractions tabulated over sun directions and closures,
  for choosing closures every control period.
"""

from flectofold_model.shading.ray_casting import (blocked_fraction, choose_candidate,
                                                  closure_for_shading, Shading, ShadingChoice,
                                                  view_fraction)
from flectofold_model.shading.table import ShadingTable

__all__ = ['Shading', 'ShadingChoice', 'ShadingTable', 'blocked_fraction', 'choose_candidate',
           'closure_for_shading', 'view_fraction']
