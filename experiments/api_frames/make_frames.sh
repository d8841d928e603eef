#!/usr/bin/env bash
# catpose.register(DepthFrame) beside bench run on the shared YCB-Video frames (38 instances):
#  - frames_ycbv.md: both paths' errors and seconds per view, and how far their poses differ.
# Usage: bash experiments/api_frames/make_frames.sh   (repository root, after `make setup`; ~1 min on 2 cores)
# Needs ../shared/data (or $CATPOSE_SHARED_DATA); skips with a note without it.
set -euo pipefail
cd "$(dirname "$0")/../.."
SHARED=${CATPOSE_SHARED_DATA:-../shared/data}
if [ ! -d "$SHARED/bop/ycbv/test" ]; then
  echo "make_frames: no $SHARED/bop/ycbv/test; skipped (set CATPOSE_SHARED_DATA)" >&2
  exit 0
fi
PYTHONWARNINGS=ignore .venv/bin/python experiments/api_frames/api_frames.py "$SHARED/bop/ycbv" results/api/frames_ycbv.md  # warnings: the frames' wide masks
