#!/usr/bin/env bash
# ctest `install: find_package(atacom) from a separate project`:
#   check_install.sh BUILD_DIR SOURCE_DIR
# installs BUILD_DIR into a temporary prefix (cmake --install), checks that no
# public header includes a private one, then configures, builds and runs
# tests/install/consumer against that prefix only.
set -euo pipefail
build=$1 src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cmake --install "$build" --prefix "$tmp/prefix" > "$tmp/install.log"
test -f "$tmp/prefix/lib/libatacom.a"
test -f "$tmp/prefix/lib/cmake/atacom/atacomConfig.cmake"
test -x "$tmp/prefix/bin/atacom"
if grep -nE '#include +"(src|train|kernels|envs)/' "$tmp"/prefix/include/atacom/*.hpp; then
  echo "install: a public header includes a private one (above)" >&2
  exit 1
fi
gen=()
command -v ninja > /dev/null && gen=(-G Ninja)
cmake -S "$src/tests/install/consumer" -B "$tmp/consumer" "${gen[@]}" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$tmp/prefix" ${CMAKE_CXX_COMPILER_LAUNCHER:+-DCMAKE_CXX_COMPILER_LAUNCHER=$CMAKE_CXX_COMPILER_LAUNCHER} \
  > "$tmp/configure.log" || { cat "$tmp/configure.log"; exit 1; }
cmake --build "$tmp/consumer" -j2 > "$tmp/build.log" 2>&1 || { cat "$tmp/build.log"; exit 1; }
"$tmp/consumer/consumer"
# The installed tool runs, with the installed data named explicitly.
ATACOM_DATA_DIR="$tmp/prefix/share/atacom/data" "$tmp/prefix/bin/atacom" rollout --env table --policy zero \
  --steps 60 --envs 2 > /dev/null
echo "install: library, headers, package config, data and tool installed; the consumer builds and runs"
