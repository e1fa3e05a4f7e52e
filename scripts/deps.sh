#!/usr/bin/env bash
# Installs the Debian 12 packages brakefit needs (only the missing ones). Sourced by demo and test.
set -euo pipefail
BRAKEFIT_DEBS=(build-essential cmake ninja-build ccache pkg-config python3 libxml2-utils can-utils
  libeigen3-dev libspdlog-dev libfmt-dev libtomlplusplus-dev libcli11-dev nlohmann-json3-dev
  libssl-dev libgtest-dev libgmock-dev libbenchmark-dev
  libmodbus-dev libsqlite3-dev sqlite3 libsystemd-dev libgpiod-dev gpiod mbpoll systemd)

brakefit_install_deps() {
  local missing=()
  for p in "${BRAKEFIT_DEBS[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -eq 0 ]; then return 0; fi
  echo "brakefit: installing missing Debian packages: ${missing[*]}"
  if [ "$(id -u)" -ne 0 ]; then
    echo "brakefit: need root to apt-get install: ${missing[*]}" >&2
    return 1
  fi
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

# brakefit_build DIR BUILD_TYPE [extra cmake args...]
brakefit_build() {
  local dir=$1 type=$2
  shift 2
  local launcher=()
  command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  # Paths under the source root hash relative, so a fresh clone elsewhere hits the same cache.
  export CCACHE_BASEDIR="$BRAKEFIT_ROOT" CCACHE_NOHASHDIR=1
  cmake -S "$BRAKEFIT_ROOT" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE="$type" -DBRAKEFIT_WERROR=ON \
    "${launcher[@]}" "$@" >/dev/null
  cmake --build "$dir" --parallel "$(nproc)"
}
