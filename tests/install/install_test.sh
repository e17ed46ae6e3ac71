#!/usr/bin/env bash
# Installs the built Trellis into a fresh temporary prefix, then configures, builds and runs a
# small external program (consumer/) against it with find_package(trellis), and runs the
# installed CLI on a route that needs a run-time module. Everything must come from the prefix.
#   install_test.sh BUILD_DIR CXX_COMPILER VERSION [EXTRA_CXX_FLAGS]
set -euo pipefail
build=$1 cxx=$2 version=$3 flags=${4:-}
here=$(cd "$(dirname "$0")" && pwd)
tmp=$(mktemp -d "${TMPDIR:-/tmp}/trellis_install_XXXXXX")
trap 'rm -rf "$tmp"' EXIT
unset TRELLIS_MODULE_DIR
prefix=$tmp/prefix

cmake --install "$build" --prefix "$prefix" >/dev/null
for f in include/trellis/version.hpp include/trellis/core/progress.hpp \
         lib/cmake/trellis/trellisConfig.cmake lib/cmake/trellis/trellisConfigVersion.cmake \
         bin/trellis; do
  [[ -e $prefix/$f ]] || { echo "not installed: $f" >&2; exit 1; }
done
ls "$prefix"/lib/libtrellis.so* >/dev/null
for m in vdb cgal cairo 3mf; do
  [[ -e $prefix/lib/trellis/trellis_$m.so ]] || { echo "module not installed: $m" >&2; exit 1; }
done

launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake -S "$here/consumer" -B "$tmp/build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="$flags" \
  -DCMAKE_PREFIX_PATH="$prefix" "${launcher[@]}" >/dev/null
cmake --build "$tmp/build" >/dev/null

# The consumer must load the installed library and the installed modules, not the build tree's.
# (ldd's output is kept first: `ldd | grep -q` under pipefail fails whenever grep stops reading
# early and ldd gets SIGPIPE.)
linked=$(ldd "$tmp/build/consumer")
grep -q "libtrellis.so.* => $prefix/lib/libtrellis.so" <<<"$linked" ||
  { echo "the consumer does not link $prefix/lib/libtrellis.so" >&2; ldd "$tmp/build/consumer" >&2; exit 1; }
LD_DEBUG=files "$tmp/build/consumer" 2>"$tmp/ld.txt"
for m in cgal vdb; do
  grep -q "file=$prefix/lib/trellis/trellis_$m.so" "$tmp/ld.txt" ||
    { echo "module $m not loaded from $prefix/lib/trellis" >&2; grep "trellis_$m" "$tmp/ld.txt" >&2; exit 1; }
done

out=$("$prefix/bin/trellis" --version)
[[ $out == "trellis $version" ]] || { echo "installed trellis --version says '$out'" >&2; exit 1; }
"$prefix/bin/trellis" lattice2d --pattern voronoi -o "$tmp/voronoi.json" >/dev/null
grep -q '"edges"' "$tmp/voronoi.json"
echo "installed into $prefix; consumer and CLI ran from it"
