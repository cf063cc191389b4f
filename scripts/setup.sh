#!/usr/bin/env bash
# Install every Debian package maskadapt needs, then configure and build it (Release) in build/.
# Idempotent: packages already present are not reinstalled, and an up-to-date build does nothing.
#
#   scripts/setup.sh               # core packages + build
#   scripts/setup.sh --with-torch  # also libtorch-dev (~800 MB) for the LibTorch benchmark peers
#   scripts/setup.sh --with-mpi    # also libopenmpi-dev + openmpi-bin: `mpirun -np K maskadapt train-base` / `train-residual`,
#                                  # maskadapt::mpi and tests/mpi (docs/distributed.md)
#   scripts/setup.sh --with-plots  # also python3-matplotlib for scripts/plot_results.py (the figures in docs/)
#   scripts/setup.sh --no-build    # packages only
#   scripts/setup.sh --cli-only    # build only the `maskadapt` command (what quickstart.sh needs)
set -euo pipefail
cd "$(dirname "$0")/.."

with_torch=0
with_mpi=0
with_plots=0
build=1
target=()
for arg in "$@"; do
  case "$arg" in
    --with-torch) with_torch=1 ;;
    --with-mpi) with_mpi=1 ;;
    --with-plots) with_plots=1 ;;
    --no-build) build=0 ;;
    --cli-only) target=(--target maskadapt_cli) ;;
    *) echo "setup.sh: unknown option '$arg'" >&2; exit 2 ;;
  esac
done

packages=(
  cmake g++ make pkg-config
  libeigen3-dev libxtensor-dev zlib1g-dev nlohmann-json3-dev libcli11-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libopenblas-dev
  libmujoco-dev
  clang            # libFuzzer targets (tests/fuzz) run in CI
  ccache           # compiler cache; CMakeLists.txt compiles through it when present (docs/development.md)
  wordnet-base     # WordNet 3.0 dictionary files (/usr/share/wordnet): prompts' unseen words → known ones (tracking/lexicon.hpp)
)
[ "$with_torch" = 1 ] && packages+=(libtorch-dev)
[ "$with_mpi" = 1 ] && packages+=(libopenmpi-dev openmpi-bin)
[ "$with_plots" = 1 ] && packages+=(python3-matplotlib)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  echo "setup.sh: installing ${missing[*]}"
  sudo_cmd=""
  [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
  $sudo_cmd apt-get update
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y "${missing[@]}"
fi

# The compiler cache holds the Release and the sanitizer build (test.sh builds both, ~3 GB) for
# every checkout on this machine; ccache's default 5 GB would evict one build type while the other
# compiles. Raise the limit to 8 GB where it is lower; a larger (or unlimited, 0) one is kept.
max_gb=$(ccache -k max_size 2>/dev/null | awk '{ s = $0; gsub(/[ B]/, "", s); n = s + 0; u = substr(s, length(s));
  if (u == "i") u = substr(s, length(s) - 1, 1);
  print n * (u == "T" ? 1000 : u == "G" ? 1 : u == "M" ? 0.001 : u == "K" ? 1e-6 : 1e-9) }')
if awk -v g="${max_gb:-0}" 'BEGIN { exit !(g > 0 && g < 8) }'; then
  echo "setup.sh: ccache max_size ${max_gb} GB -> 8 GB"
  ccache -M 8G >/dev/null
fi

if [ "$build" = 1 ]; then
  extra=()
  [ "$with_torch" = 1 ] && extra+=(-DMASKADAPT_WITH_TORCH=ON)
  packages_s=$SECONDS
  cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "${extra[@]}" >/dev/null
  cmake --build build -j"$(nproc)" "${target[@]}"
  # (test.sh reads these two lines for its per-stage times)
  echo "setup.sh: packages and checks took ${packages_s} s, the Release build $((SECONDS - packages_s)) s"
fi
