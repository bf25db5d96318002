#!/usr/bin/env bash
# Sourced by demo.sh and test.sh: installs what roadpreview needs on a fresh Debian machine and builds it.
#   - Debian packages (C++ libraries), with apt-get, only those not yet installed;
#   - a virtual environment in .venv with the build tools, then `pip install .[test]`, which builds the
#     C++ core, the Python extension and the `roadpreview` CLI.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
DEBIAN_PACKAGES=(g++ make pkg-config python3-venv python3-dev libpcl-dev libboost-dev libeigen3-dev nlohmann-json3-dev
                 rapidjson-dev libtbb-dev libyaml-cpp-dev libcli11-dev libgtest-dev libpcap-dev libtins-dev liblz4-dev
                 time libopencv-dev opencv-data libpng-dev libgeographiclib-dev libdlib-dev zlib1g-dev)

log() { printf '\033[1m[setup]\033[0m %s\n' "$*" >&2; }

install_debian_packages() {
    local missing=()
    for pkg in "${DEBIAN_PACKAGES[@]}"; do
        dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
    done
    [ ${#missing[@]} -eq 0 ] && return
    log "installing Debian packages: ${missing[*]}"
    local sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
}

install_python_package() {
    if [ ! -x "$ROOT/.venv/bin/python" ]; then
        log "creating virtual environment .venv"
        python3 -m venv "$ROOT/.venv"
    fi
    # shellcheck disable=SC1091
    source "$ROOT/.venv/bin/activate"
    log "installing build tools and roadpreview (compiles the C++ core; about a minute)"
    python -m pip install -q --upgrade pip
    python -m pip install -q cmake ninja
    python -m pip install -q "$ROOT[test]"
}

install_debian_packages
install_python_package
