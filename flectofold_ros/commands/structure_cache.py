"""Compute a facade's structural cushion map once, so that its processes start in seconds.

``structure_cache [--facade FILE]``: for a facade whose description says
``actuation: {cushion_map: structural}``, trace the structural path of its median panel
(about 10 s of CPU) into the cache (``$FLECTOFOLD_STRUCTURE_CACHE``, default
``~/.cache/flectofold/structure``), or find it there, and print what the map says. Panel
processes and the coordinator only read that cache: without the entry they refuse to start,
naming this command. ``facade`` runs it before it starts its panels. Exit code 2 for a facade
that cannot be loaded or whose median panel does not close in the structure.
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
    if facade.cushion_map != 'structural':
        return None
    median = facade.panel_ids[representative_index(facade)]
    try:
        cushion_map = median_structural_map(facade, trace=False)
        how = 'cached'
    except NotCached:
        print(f'{name}: tracing the structural path of the median panel {median} of {facade.name} '
              f'(about 10 s of CPU, once; cached in {cache_directory()})', flush=True)
        started = time.process_time()
        last = [time.monotonic()]

        def progress(pressure_pa, apex_fold_rad):
            if time.monotonic() - last[0] >= 10.0:
                last[0] = time.monotonic()
                print(f'{name}: ... {pressure_pa / 1e3:.2f} kPa, apex fold '
                      f'{math.degrees(apex_fold_rad):.1f} deg', flush=True)

        cushion_map = median_structural_map(facade, trace=True, progress=progress)
        how = f'traced in {time.process_time() - started:.0f} s of CPU'
    pressure, volume = (table[0] for table in cushion_map.tables()[:2])
    print(f'{name}: structural cushion map of {facade.name} (median panel {median}), {how}: '
          f'closed at {pressure[-1] / 1e3:.2f} kPa, cushion {volume[0] * 1e3:.2f} L open, '
          f'{volume[-1] * 1e3:.2f} L closed', flush=True)
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
