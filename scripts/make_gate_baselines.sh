#!/usr/bin/env bash
# Regenerates tests/gate/baselines.yaml: replays each case's window of its committed recording
# (CPU backend, async mode) and records the force-quality metrics the gate compares against.
# Run it after a change that is meant to alter the forces, and commit the result with the reason.
#   scripts/make_gate_baselines.sh [path/to/ebh]
set -euo pipefail
cd "$(dirname "$0")/.."
EBH=${1:-build/ebh}
"$EBH" gate --update --baselines tests/gate/baselines.yaml
