#!/usr/bin/env bash
# Sets up ebh on Debian 12 / Ubuntu 24.04: installs the Debian packages it needs (apt-get, as
# root or with sudo), configures and builds into build/. Idempotent: a second run only rebuilds.
#
#   scripts/setup.sh            install + build
#   scripts/setup.sh --test     install + build + run the whole test suite (ctest)
#
# Environment: BUILD_DIR (default build), JOBS (default: number of cores), CMAKE_ARGS (extra),
# EBH_SKIP_APT=1 to skip the package step (e.g. on the GPU machine, which has no package access).
set -euo pipefail
cd "$(dirname "$0")/.."

run_tests=0
for arg in "$@"; do
  case "$arg" in
    --test) run_tests=1 ;;
    -h|--help) sed -n '2,11p' "$0"; exit 0 ;;
    *) echo "setup.sh: unknown option '$arg' (try --help)" >&2; exit 2 ;;
  esac
done

BUILD_DIR=${BUILD_DIR:-build}
JOBS=${JOBS:-$(nproc)}
PACKAGES=(build-essential cmake ninja-build pkg-config libeigen3-dev libhdf5-dev libcli11-dev
          libgtest-dev libgmock-dev libbenchmark-dev libyaml-cpp-dev libpng-dev zlib1g-dev libbz2-dev liblz4-dev libzstd-dev libosmesa6-dev
          python3 python3-h5py python3-matplotlib python3-numpy
          slurmctld slurmd slurm-client munge)  # the last four: ebh sweep's Slurm test (tests/sweep/slurm.sh)

if [ "${EBH_SKIP_APT:-0}" != 1 ]; then
  missing=()
  for p in "${PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    SUDO=""
    [ "$(id -u)" -eq 0 ] || SUDO="sudo"
    echo "setup.sh: installing ${missing[*]}"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
  fi
fi

generator=()
command -v ninja >/dev/null && [ ! -f "$BUILD_DIR/Makefile" ] && generator=(-G Ninja)
# shellcheck disable=SC2086
cmake -S . -B "$BUILD_DIR" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release ${CMAKE_ARGS:-}
cmake --build "$BUILD_DIR" -j "$JOBS"

if [ $run_tests = 1 ]; then
  # The long replays and stress cases carry the label 'long' and run here in their short form;
  # EBH_LONG=1 runs them in full (see README, Tests).
  ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$JOBS"
fi
