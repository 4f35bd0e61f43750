#!/usr/bin/env bash
# Build the Ceres peer (bench/ceres/peer_ceres) with the system's Ceres 2.1 and Eigen 3
# (Debian/Ubuntu: libceres-dev, installed here with apt-get when its headers are missing).
#   bash bench/ceres/build.sh          (CXX=clang++ to use another compiler)
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
CXX=${CXX:-g++}

if [ ! -f /usr/include/ceres/ceres.h ]; then
    echo "build.sh: Ceres headers missing; installing libceres-dev with apt-get ..." >&2
    SUDO=
    [ "$(id -u)" = 0 ] || SUDO=sudo
    if ! { $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq libceres-dev; } >&2; then
        echo "build.sh: could not install libceres-dev (apt-get install -y libceres-dev)" >&2
        exit 1
    fi
fi
command -v "$CXX" >/dev/null || { echo "build.sh: no C++ compiler ($CXX)" >&2; exit 1; }

# Debian's libceres-dev ships CMake files but no ceres.pc: Eigen, glog and gflags flags come
# from pkg-config when it knows them, the rest is given directly.
CFLAGS="-I/usr/include/eigen3"
LIBS="-lceres -lglog -lgflags -lpthread"
if command -v pkg-config >/dev/null && pkg-config --exists eigen3 libglog gflags 2>/dev/null; then
    CFLAGS=$(pkg-config --cflags eigen3 libglog gflags)
    LIBS="-lceres $(pkg-config --libs libglog gflags) -lpthread"
fi

echo "build.sh: $CXX -std=c++17 -O3 -march=native ... -> $HERE/peer_ceres" >&2
# shellcheck disable=SC2086
# Into a file of its own, then renamed: two builds at once never share a half-written binary.
tmp=$(mktemp "$HERE/peer_ceres.XXXXXX")
trap 'rm -f "$tmp"' EXIT
"$CXX" -std=c++17 -O3 -march=native -DNDEBUG $CFLAGS "$HERE/peer_ceres.cpp" -o "$tmp" $LIBS
mv "$tmp" "$HERE/peer_ceres"
echo "build.sh: built $HERE/peer_ceres" >&2
