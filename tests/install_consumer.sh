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
# A C-only project asking for sinew::shared alone configures without Eigen and libccd.
cmake -S "$source_dir/demos/cmake-consumer" -B "$prefix/build-c" -G Ninja -DCMAKE_PREFIX_PATH="$prefix/usr" \
  -DSINEW_CONSUMER_C_ONLY=ON -DCMAKE_DISABLE_FIND_PACKAGE_Eigen3=ON -DCMAKE_DISABLE_FIND_PACKAGE_ccd=ON >/dev/null
cmake --build "$prefix/build-c" >/dev/null
LD_LIBRARY_PATH="$prefix/usr/lib:$prefix/usr/lib/x86_64-linux-gnu:${LD_LIBRARY_PATH:-}" "$prefix/build-c/consumer_c"
# A C-only project may link the static library (sinew.h, the C++ runtime and libm come with it).
cmake -S "$source_dir/demos/cmake-consumer" -B "$prefix/build-cs" -G Ninja -DCMAKE_PREFIX_PATH="$prefix/usr" \
  -DSINEW_CONSUMER_C_STATIC=ON >/dev/null
cmake --build "$prefix/build-cs" >/dev/null
"$prefix/build-cs/consumer_c"
# Headers internal to a layer (CMakeLists.txt SINEW_INTERNAL_HEADERS) are not installed.
test ! -e "$prefix/usr/include/sinew/rigid/joint_rows.hpp" && test ! -e "$prefix/usr/include/sinew/soft/solver_caches.hpp"
# pkg-config from the installed prefix (the .pc finds its prefix from its own location), and the tool.
pc_dir=$(dirname "$(find "$prefix/usr" -name sinew.pc | head -1)")
cc_flags=$(PKG_CONFIG_PATH="$pc_dir" pkg-config --cflags --libs sinew)
case "$cc_flags" in *"$prefix/usr"*) ;; *) echo "install: pkg-config points outside the prefix: $cc_flags" >&2; exit 1 ;; esac
cc -std=c99 -o "$prefix/pc_consumer" "$source_dir/demos/cmake-consumer/main.c" $cc_flags
LD_LIBRARY_PATH="$(PKG_CONFIG_PATH="$pc_dir" pkg-config --variable=libdir sinew):${LD_LIBRARY_PATH:-}" "$prefix/pc_consumer"
if [ -d "$build_dir/tools" ]; then
  "$prefix/usr/bin/sinew" validate "$source_dir/demos/scenes/pyramid-10.json" >/dev/null
fi
echo "install: find_package(sinew) and pkg-config consumers built and ran; the sinew tool runs from the prefix"
