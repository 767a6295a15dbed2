"""Compute a facade's structural cushion map once, so that its processes start in seconds.

``structure_cache [--facade FILE]``: for a facade whose description says
``actuation: {cushion_map: structural}``, trace the structural path of its median panel
(about 15 s of CPU) into the cache (``$FLECTOFOLD_STRUCTURE_CACHE``, default
``~/.cache/flectofold/structure``), or find it there, and print what the map says; with
``structural_per_panel``, the path of every distinct panel design, one after the other, a
line for each. Panel processes and the coordinator only read that cache: without the entry
they refuse to start, naming this command. ``facade`` runs it before it starts its panels.
Exit code 2 for a facade that cannot be loaded or whose panel (the median, or any with
``structural_per_panel``) does not close in the structure.
Details: ``msg_docs/structure.md``.
"""

import argparse
import math
import sys
import time

from flectofold_ros.runtime.runner import run_command


def parse_arguments(argv):
    parser = argparse.ArgumentParser(prog='structure_cache', description=__doc__.split('\n')[0])
    parser.add_argument('--facade', help='facade description (YAML file or embedded name; '
                        'default: the embedded demonstrator)')
    return parser.parse_args(argv)


def prepare_structural_map(facade, name):
    """Trace (or find cached) the structural map ``facade`` chooses; print one line each.

    Return the map, or None for a facade that keeps the energy statics. ``name`` prefixes
    the lines (the executable's).
    """
    from flectofold_model.facade.footprint import representative_index
    from flectofold_model.structure.cushion_tables import cache_directory, NotCached
    from flectofold_model.structure.facade_map import median_structural_map
    if facade.cushion_map == 'energy':
        return None
    if facade.cushion_map == 'structural_per_panel':
        return _prepare_every_panel(facade, name)
    median = facade.panel_ids[representative_index(facade)]
    try:
        cushion_map = median_structural_map(facade, trace=False)
        how = 'cached'
    except NotCached:
        print(f'{name}: tracing the structural path of the median panel {median} of {facade.name} '
              f'(about 15 s of CPU, once; cached in {cache_directory()})', flush=True)
        started = time.process_time()
        cushion_map = median_structural_map(facade, trace=True, progress=_progress(name))
        how = f'traced in {time.process_time() - started:.0f} s of CPU'
    pressure, volume = (table[0] for table in cushion_map.tables()[:2])
    print(f'{name}: structural cushion map of {facade.name} (median panel {median}), {how}: '
          f'closed at {pressure[-1] / 1e3:.2f} kPa, cushion {volume[0] * 1e3:.2f} L open, '
          f'{volume[-1] * 1e3:.2f} L closed', flush=True)
    return cushion_map


def _progress(name):
    """Return a path tracer's progress callback that prints a line at most every 10 s."""
    last = [time.monotonic()]

    def progress(pressure_pa, apex_fold_rad):
        if time.monotonic() - last[0] >= 10.0:
            last[0] = time.monotonic()
            print(f'{name}: ... {pressure_pa / 1e3:.2f} kPa, apex fold '
                  f'{math.degrees(apex_fold_rad):.1f} deg', flush=True)
    return progress


def _prepare_every_panel(facade, name):
    """:func:`prepare_structural_map` for ``structural_per_panel``: every distinct design."""
    from flectofold_model.actuation.cushion_map import distinct_panels
    from flectofold_model.structure.cushion_tables import (cache_directory, NotCached,
                                                           structural_tables)
    from flectofold_model.structure.facade_map import (facade_structural_panels,
                                                       panels_structural_map)
    panels = facade_structural_panels(facade)
    distinct, row = distinct_panels(panels)
    missing = []
    for design, panel in enumerate(distinct):
        try:
            structural_tables(panel, trace=False)
        except NotCached:
            missing.append(design)
    if missing:
        print(f'{name}: tracing the structural paths of {len(missing)} of the {len(distinct)} '
              f'panel designs of {facade.name} (about 15 s of CPU each, once; cached in '
              f'{cache_directory()})', flush=True)
    started = time.process_time()
    for count, design in enumerate(missing, 1):
        ids = [facade.panel_ids[i] for i in range(len(panels)) if row[i] == design]
        began = time.process_time()
        try:
            pressure, volume, _, _ = structural_tables(distinct[design], trace=True,
                                                       progress=_progress(name))
        except ValueError as error:
            raise ValueError(f'panel {ids[0]} of {facade.name}: {error}') from None
        print(f'{name}: {count}/{len(missing)} panel {", ".join(ids)}: closed at '
              f'{pressure[-1] / 1e3:.2f} kPa, cushion {volume[0] * 1e3:.2f} L open, '
              f'{volume[-1] * 1e3:.2f} L closed ({time.process_time() - began:.0f} s of CPU)',
              flush=True)
    cushion_map = panels_structural_map(facade, panels, trace=False)
    how = (f'traced {len(missing)} in {time.process_time() - started:.0f} s of CPU'
           if missing else 'cached')
    pressure, volume = (table for table in cushion_map.tables()[:2])
    print(f'{name}: structural cushion maps of the {len(panels)} panels of {facade.name} '
          f'({len(distinct)} designs), {how}: closed at {pressure[:, -1].min() / 1e3:.2f}-'
          f'{pressure[:, -1].max() / 1e3:.2f} kPa, cushion {volume[:, 0].min() * 1e3:.2f}-'
          f'{volume[:, 0].max() * 1e3:.2f} L open, {volume[:, -1].min() * 1e3:.2f}-'
          f'{volume[:, -1].max() * 1e3:.2f} L closed', flush=True)
    return cushion_map


def cache_and_report(facade_file):
    from flectofold_model.facade import DEFAULT_FACADE, load_facade
    facade = load_facade(facade_file or DEFAULT_FACADE)
    if prepare_structural_map(facade, 'structure_cache') is None:
        print(f'structure_cache: facade {facade.name} takes its cushion map from the energy '
              f'statics (actuation.cushion_map: energy): nothing to compute', flush=True)
    return 0


def main(args=None):
    """``structure_cache [--facade FILE]``."""
    options = parse_arguments((sys.argv if args is None else args)[1:])
    return run_command('structure_cache', lambda stop: cache_and_report(options.facade),
                       interrupted_code=130)


if __name__ == '__main__':
    sys.exit(main())
