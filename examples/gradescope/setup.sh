#!/usr/bin/env bash
# Gradescope runs this once, as root, when it builds the autograder's image (an Ubuntu image;
# it has run `apt-get update` first). It installs kr210_sim from the wheel that you put in
# the autograder's zip beside this script and run_autograder (docs/how-to/gradescope.md).
set -euo pipefail

SOURCE="${SOURCE:-/autograder/source}"
# kr210_sim needs Python 3.11 or newer: the image's own when it has one, else Ubuntu's package.
if ! python3 -c 'import sys; sys.exit(sys.version_info < (3, 11))' 2>/dev/null; then
  apt-get install -y --no-install-recommends python3.11 python3.11-venv
  PY=python3.11
else
  apt-get install -y --no-install-recommends python3-venv
  PY=python3
fi
"$PY" -m venv /autograder/venv
/autograder/venv/bin/python -m pip install --upgrade pip
/autograder/venv/bin/python -m pip install "$SOURCE"/kr210_sim-*.whl
# The jail's check: fails the image's build here, with what to do, rather than every submission.
/autograder/venv/bin/python -c 'from kr210_sim.sandbox.jail import Jail; Jail().describe()'
