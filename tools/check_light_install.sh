#!/usr/bin/env bash
# A plain `pip install .` of this checkout in a fresh virtual environment: no CUDA build, no GPL code.
#
#   bash tools/check_light_install.sh            (repository root; needs PyPI, ~600 MB of wheels)
#
# Fails when the install brought any nvidia-* package, triton, torch or kmedoids, then runs
# `bench run method=ours dataset=synthetic limit=2` in a scratch folder with that environment and
# checks that `method.optimiser.solver=adam` (the torch extra) stops in one line naming the extra.
# SCRATCH (default /tmp/catpose-light-install) holds the environment; PYTHON picks the interpreter.
set -euo pipefail
cd "$(dirname "$0")/.."
REPO=$(pwd)
SCRATCH=${SCRATCH:-/tmp/catpose-light-install}
rm -rf "$SCRATCH/venv" "$SCRATCH/run"
mkdir -p "$SCRATCH/run"
"${PYTHON:-python3}" -m venv "$SCRATCH/venv"
PY="$SCRATCH/venv/bin/python"
"$PY" -m pip install --quiet --upgrade pip
"$PY" -m pip install --quiet "$REPO"
"$PY" -m pip list --format=freeze > "$SCRATCH/packages.txt"
echo "check_light_install: $(wc -l < "$SCRATCH/packages.txt") packages ($SCRATCH/packages.txt)"
if grep -iE '^(nvidia-|triton|torch|kmedoids)' "$SCRATCH/packages.txt"; then
  echo "check_light_install: FAILED: the packages above came with a plain pip install" >&2
  exit 1
fi
cd "$SCRATCH/run"
"$SCRATCH/venv/bin/bench" run method=ours dataset=synthetic limit=2 progress=false
set +e
err=$("$SCRATCH/venv/bin/bench" run method=ours dataset=synthetic limit=1 method.optimiser.solver=adam progress=false 2>&1 >/dev/null)
code=$?
set -e
if [ "$code" -ne 2 ] || [ "$(printf '%s\n' "$err" | wc -l)" -ne 1 ] || [[ "$err" != *"catpose[torch]"* ]]; then
  echo "check_light_install: FAILED: solver=adam without torch gave exit $code: $err" >&2
  exit 1
fi
echo "check_light_install: without torch, solver=adam stops in one line: $err"
echo "check_light_install: ok"
