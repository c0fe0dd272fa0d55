#!/bin/sh
# Makes the peer venv of tools/peers/run.py from tools/peers/requirements.txt and checks that
# every peer imports. Usage: tools/peers/setup.sh [VENV]
# (default: ${XDG_CACHE_HOME:-~/.cache}/robosim-peers-venv, outside the checkout)
# Needs python3.11 (or python3 >= 3.9) with venv, and the package index.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
venv=${1:-${XDG_CACHE_HOME:-$HOME/.cache}/robosim-peers-venv}
py=${PYTHON:-python3.11}
command -v "$py" >/dev/null 2>&1 || py=python3
"$py" -m venv "$venv"
"$venv/bin/pip" install --upgrade pip
"$venv/bin/pip" install -r "$here/requirements.txt"
"$venv/bin/python" - <<'PY'
import glob, sys
import coal, fcl, mujoco, numpy, pinocchio, roboticstoolbox
assert glob.glob(sys.prefix + '/lib/python3*/site-packages/cmeel.prefix/share/example-robot-data/robots'), 'example-robot-data'
print("peers:", "pinocchio", pinocchio.__version__, "| coal", coal.__version__ if hasattr(coal, "__version__") else "3.x",
      "| mujoco", mujoco.__version__, "| roboticstoolbox", roboticstoolbox.__version__, "| numpy", numpy.__version__)
PY
echo "venv ready: $venv  (from $root: $venv/bin/python tools/peers/run.py)"
