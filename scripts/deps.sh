#!/usr/bin/env bash
# Installs the Debian 12 packages brakefit needs (only the missing ones). Sourced by demo and test.
set -euo pipefail
# What building needs (scripts/demo installs these only) ...
BRAKEFIT_BUILD_DEBS=(build-essential cmake ninja-build ccache pkg-config python3
  libeigen3-dev libspdlog-dev libfmt-dev libtomlplusplus-dev libcli11-dev nlohmann-json3-dev
  libssl-dev libgtest-dev libgmock-dev libbenchmark-dev
  libmodbus-dev libsqlite3-dev libsystemd-dev libgpiod-dev libceres-dev libpq-dev help2man)
# ... and what the tests run against (scripts/test adds these): third-party clients and tools, and
# numpy, which generator C (../shared/gapgen, run by the referee's tests) imports.
BRAKEFIT_TEST_DEBS=(libxml2-utils can-utils sqlite3 gpiod mbpoll systemd lintian man-db
  postgresql-15 openssl python3-numpy)

# brakefit_install_deps [test]: installs the missing packages only, never upgrading an installed
# one (--no-upgrade). Without root, nothing is installed: it names what is missing and the command
# to run as root, and fails; with everything present it needs no root at all.
brakefit_install_deps() {
  local want=("${BRAKEFIT_BUILD_DEBS[@]}") missing=()
  [ "${1:-}" = test ] && want+=("${BRAKEFIT_TEST_DEBS[@]}")
  for p in "${want[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -eq 0 ]; then return 0; fi
  if [ "$(id -u)" -ne 0 ]; then
    echo "brakefit: missing Debian packages: ${missing[*]}" >&2
    echo "brakefit: as root, run: apt-get install --no-install-recommends --no-upgrade ${missing[*]}" >&2
    return 1
  fi
  echo "brakefit: installing missing Debian packages (no upgrades): ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends --no-upgrade "${missing[@]}"
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
