"""``python -m flectofold_ros NAME [ARGS ...]``: run one of the package's executables."""

import sys

from flectofold_ros.runtime.executables import EXECUTABLES, exit_with, run

if len(sys.argv) < 2 or sys.argv[1] not in EXECUTABLES:
    print(f'usage: python -m flectofold_ros {{{",".join(EXECUTABLES)}}} [ARGS ...]',
          file=sys.stderr)
    sys.exit(2)
exit_with(sys.argv[1], run(sys.argv[1], sys.argv[1:], ending=True))
