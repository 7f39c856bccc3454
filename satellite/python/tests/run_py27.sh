#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Runs test modules of this suite (and so the example sketches, which run under the same
# interpreter) under Python 2.7.18, against a real hub. Every machine of the project has it at
# the pyenv path below ($PYSKETCH_PY27 overrides). Without it: skipped (exit 77, CTest's
# SKIP_RETURN_CODE), except under CI=true, where that is a failure.
PY27=${PYSKETCH_PY27:-/root/.pyenv/versions/2.7.18/bin/python2.7}
if [ ! -x "$PY27" ]; then
  if [ "$CI" = true ]; then
    echo "FAIL: no Python 2.7 interpreter at $PY27 (CI=true: PySketch must be tested under 2.7)"
    exit 1
  fi
  echo "SKIP: no Python 2.7 interpreter at $PY27: PySketch not tested under Python 2.7"
  exit 77
fi
exec "$PY27" -m unittest -v "$@"
