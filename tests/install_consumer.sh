#!/usr/bin/env bash
# Installs the build tree into a temporary prefix and builds and runs demos/cmake-consumer against it:
# find_package(sinew) must work from an installed prefix, for C++ (static) and C (shared) users.
set -euo pipefail
build_dir=$1 source_dir=$2
prefix=$(mktemp -d)
trap 'rm -rf "$prefix"' EXIT
cmake --install "$build_dir" --prefix "$prefix/usr" >/dev/null
cmake -S "$source_dir/demos/cmake-consumer" -B "$prefix/build" -G Ninja -DCMAKE_PREFIX_PATH="$prefix/usr" >/dev/null
cmake --build "$prefix/build" >/dev/null
"$prefix/build/consumer_cpp"
LD_LIBRARY_PATH="$prefix/usr/lib:$prefix/usr/lib/x86_64-linux-gnu:${LD_LIBRARY_PATH:-}" "$prefix/build/consumer_c"
# Headers internal to a layer (CMakeLists.txt SINEW_INTERNAL_HEADERS) are not installed.
test ! -e "$prefix/usr/include/sinew/rigid/joint_rows.hpp" && test ! -e "$prefix/usr/include/sinew/soft/solver_caches.hpp"
test -f "$prefix/usr/lib/pkgconfig/sinew.pc" || test -f "$prefix/usr/lib/x86_64-linux-gnu/pkgconfig/sinew.pc"
echo "install: find_package(sinew) consumer built and ran"
