#!/usr/bin/env bash
# physval's battery on this plug-in's engine, as a CI step: run from the plug-in's folder.
#   PHYSVAL       what pip installs physval from: a wheel, a source folder, or a git URL
#                 ("physval[mujoco] @ git+URL"); required (physval is not on the package index)
#   ENGINES       the engines to judge (default: this package's, mujoco-soft)
#   CASES         the families (default: the conformance battery and the core families)
#   OUT           where the results, report and JUnit XML go (default: physval-out)
# Exit code: physval's own: 0 nothing under --fail-on, 1 a check under it, 2 bad input.
set -euo pipefail
cd "$(dirname "$0")/.."
: "${PHYSVAL:?set PHYSVAL to what pip installs physval from (a wheel, a folder or a git URL)}"
ENGINES=${ENGINES:-mujoco-soft}
CASES=${CASES:-"conformance central_impact incline_threshold resting_blocks"}
OUT=${OUT:-physval-out}
python3 -m pip install -q "$PHYSVAL"
python3 -m pip install -q .
physval list --engines | grep -E "^(${ENGINES// /|})\b"      # the plug-in is found
# shellcheck disable=SC2086  # CASES and ENGINES are lists
physval run --engines $ENGINES --cases $CASES --readings none --out "$OUT" \
    --junitxml "$OUT/physval.xml" --fail-on fail,error,unstable,changed
