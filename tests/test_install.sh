#!/usr/bin/env bash
# The installed vdbscatter, used the way a user would with nothing of the build tree on any
# path: `cmake --install BUILD --prefix TMP`, then
#   1. a C program built with `pkg-config --cflags --libs vdbscatter` bakes a sample and reads
#      its radiance (tests/install/bake_sample.c); the same program linked statically
#      (pkg-config --static against the archives alone);
#   2. the same program built by CMake with find_package(vdbscatter CONFIG);
#   3. the Python package, alone on PYTHONPATH, bakes, renders, compares and reads a lit VDB
#      (tests/install/use_python.py);
#   4. `man vdbscatter-bake` shows the installed page;
#   5. libvdbscatter.so.0 exports only vdbs_* symbols and has the SONAME libvdbscatter.so.0;
#   6. include/vdbscatter holds exactly the public headers, which compile on their own.
# Usage: tests/test_install.sh BUILD_DIR SOURCE_DIR [PYTHON]  (ctest gives them)
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: tests/test_install.sh BUILD_DIR SOURCE_DIR [PYTHON]" >&2
  exit 2
fi
build=$(cd "$1" && pwd)
src=$(cd "$2" && pwd)
python=${3:-/usr/bin/python3}
cmake=${CMAKE:-cmake}
cc=${CC:-cc}
cxx=${CXX:-c++}
version=$(sed -n 's/^CMAKE_PROJECT_VERSION:[A-Z]*=//p' "$build/CMakeCache.txt")
pydir=$(sed -n 's/^VDBSCATTER_INSTALL_PYTHONDIR:[A-Z]*=//p' "$build/CMakeCache.txt")

fail() {
  echo "test_install: FAIL: $*" >&2
  exit 1
}
step() {
  echo "test_install: $*"
}
[ -n "$version" ] || fail "no CMAKE_PROJECT_VERSION in $build/CMakeCache.txt"
[ -n "$pydir" ] || fail "no VDBSCATTER_INSTALL_PYTHONDIR in $build/CMakeCache.txt"

# Nothing of the build tree (or of an earlier install) may be found through the environment.
unset LD_LIBRARY_PATH LIBRARY_PATH CPATH C_INCLUDE_PATH PYTHONPATH PYTHONHOME PKG_CONFIG_PATH \
  CMAKE_PREFIX_PATH VDBSCATTER_LIBRARY MANPATH
prefix=$(mktemp -d "${TMPDIR:-/tmp}/vdbscatter-install.XXXXXX")
trap 'rm -rf "$prefix"' EXIT
work=$prefix/work
mkdir -p "$work"

step "cmake --install $build --prefix $prefix"
"$cmake" --install "$build" --prefix "$prefix" >"$work/install.log" 2>&1 ||
  { cat "$work/install.log" >&2; fail "cmake --install failed"; }

for f in bin/vdbscatter bin/vdbscatter-view lib/libvdbscatter.so lib/libvdbscatter.so.0 \
  "lib/libvdbscatter.so.$version" lib/libvdbscatter.a lib/pkgconfig/vdbscatter.pc \
  lib/cmake/vdbscatter/vdbscatterConfig.cmake lib/cmake/vdbscatter/vdbscatterConfigVersion.cmake \
  "$pydir/vdbscatter/__init__.py"; do
  [ -e "$prefix/$f" ] || fail "not installed: $f"
done
[ -L "$prefix/lib/libvdbscatter.so" ] || fail "lib/libvdbscatter.so is not the namelink"
[ "$("$prefix/bin/vdbscatter" --version)" = "vdbscatter $version" ] ||
  fail "the installed bin/vdbscatter --version does not print 'vdbscatter $version'"
# Debian's python3 reads PREFIX/$pydir for the default prefix /usr/local.
if "$python" -c 'import sysconfig, sys; sys.exit(sysconfig.get_default_scheme() != "posix_local")'; then
  "$python" -c 'import sys; sys.exit("/usr/local/" + sys.argv[1] not in sys.path)' "$pydir" ||
    fail "$python does not read /usr/local/$pydir: the Python package would not be found there"
fi

# The radiance line of bake_sample's output: channels 3, a size, a finite positive maximum.
check_bake_output() {
  local what=$1 out=$2
  echo "$out" | grep -qx "version $version" || fail "$what: no 'version $version' line: $out"
  local line
  line=$(echo "$out" | grep '^radiance ') || fail "$what: no radiance line: $out"
  echo "$line" | grep -Eq '^radiance channels=3 size=[1-9][0-9]*x[1-9][0-9]*x[1-9][0-9]* max=[0-9.e+-]+ finite=1$' ||
    fail "$what: unexpected radiance line: $line"
  local max=${line#*max=}
  max=${max%% *}
  awk -v m="$max" 'BEGIN { exit !(m + 0 > 0) }' || fail "$what: radiance max $max is not positive"
  step "$what: $line"
}

# Which libvdbscatter a program loads: the installed one.
check_loads_installed() {
  local what=$1 exe=$2 lib
  lib=$(ldd "$exe" | awk '$1 == "libvdbscatter.so.0" { print $3 }')
  [ "$lib" = "$prefix/lib/libvdbscatter.so.0" ] ||
    fail "$what loads libvdbscatter.so.0 from '$lib', not from $prefix/lib"
}

# --- 1. pkg-config -------------------------------------------------------------------------
export PKG_CONFIG_PATH=$prefix/lib/pkgconfig
[ "$(pkg-config --variable=prefix vdbscatter)" = "$prefix" ] ||
  fail "pkg-config's vdbscatter prefix is $(pkg-config --variable=prefix vdbscatter), not $prefix"
[ "$(pkg-config --modversion vdbscatter)" = "$version" ] || fail "pkg-config --modversion is not $version"
step "pkg-config --cflags --libs vdbscatter: $(pkg-config --cflags --libs vdbscatter)"
mkdir -p "$work/pc"
# shellcheck disable=SC2046 # pkg-config's words
"$cc" -std=c11 -Wall -Wextra -Werror -o "$work/pc/bake_sample" "$src/tests/install/bake_sample.c" \
  $(pkg-config --cflags --libs vdbscatter) -Wl,-rpath,"$prefix/lib" ||
  fail "the pkg-config build failed"
check_loads_installed "the pkg-config build" "$work/pc/bake_sample"
out=$("$work/pc/bake_sample" "$work/pc") || fail "the pkg-config build's bake_sample exited $?: $out"
check_bake_output "pkg-config build" "$out"
[ -s "$work/pc/lit.vdb" ] || fail "the pkg-config build wrote no lit.vdb"

# Statically: a prefix holding the archives but not the shared library.
static=$work/static-prefix
mkdir -p "$static/lib"
cp -a "$prefix/include" "$static/"
cp -a "$prefix/lib/pkgconfig" "$prefix"/lib/*.a "$static/lib/"
sed -i "s|^prefix=.*|prefix=$static|" "$static/lib/pkgconfig/vdbscatter.pc"
mkdir -p "$work/static"
# shellcheck disable=SC2046
PKG_CONFIG_PATH=$static/lib/pkgconfig \
  "$cc" -std=c11 -o "$work/static/bake_sample" "$src/tests/install/bake_sample.c" \
  $(PKG_CONFIG_PATH=$static/lib/pkgconfig pkg-config --static --cflags --libs vdbscatter) ||
  fail "the static link with pkg-config --static failed (the .pc file's Libs.private)"
if ldd "$work/static/bake_sample" | grep -q libvdbscatter; then
  fail "the static build loads a libvdbscatter"
fi
out=$("$work/static/bake_sample" "$work/static") || fail "the static build's bake_sample exited $?: $out"
check_bake_output "static pkg-config build" "$out"

# --- 2. find_package -----------------------------------------------------------------------
export CMAKE_PREFIX_PATH=$prefix
"$cmake" -S "$src/tests/install" -B "$work/cmake" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_C_COMPILER="$cc" >"$work/cmake.log" 2>&1 ||
  { cat "$work/cmake.log" >&2; fail "configuring the find_package consumer failed"; }
grep -qx "vdbscatter_DIR:PATH=$prefix/lib/cmake/vdbscatter" "$work/cmake/CMakeCache.txt" ||
  fail "find_package found $(grep '^vdbscatter_DIR' "$work/cmake/CMakeCache.txt"), not $prefix"
"$cmake" --build "$work/cmake" >>"$work/cmake.log" 2>&1 ||
  { cat "$work/cmake.log" >&2; fail "building the find_package consumer failed"; }
check_loads_installed "the find_package build" "$work/cmake/bake_sample"
out=$("$work/cmake/bake_sample" "$work/cmake") || fail "the find_package build's bake_sample exited $?: $out"
check_bake_output "find_package build" "$out"

# --- 3. Python -----------------------------------------------------------------------------
mkdir -p "$work/py"
out=$(cd "$work/py" && PYTHONPATH=$prefix/$pydir "$python" -s "$src/tests/install/use_python.py" \
  "$prefix" "$work/py") || fail "the Python script exited $?: $out"
echo "$out" | grep -qx "python ok" || fail "the Python script did not finish: $out"
step "python: $(echo "$out" | tr '\n' ' ')"

# --- 4. man pages --------------------------------------------------------------------------
for page in vdbscatter vdbscatter-bake vdbscatter-render vdbscatter-compare vdbscatter-info \
  vdbscatter-sample vdbscatter-tradeoff vdbscatter-phase-svd vdbscatter-view; do
  [ -s "$prefix/share/man/man1/$page.1" ] || fail "no man page share/man/man1/$page.1"
done
text=$(MANPATH=$prefix/share/man MANPAGER=cat LC_ALL=C.UTF-8 man -P cat vdbscatter-bake 2>&1) ||
  fail "man vdbscatter-bake failed: $text"
echo "$text" | grep -q -- '--density-scale' || fail "man vdbscatter-bake lacks --density-scale: $text"
echo "$text" | grep -q '^NAME' || fail "man vdbscatter-bake has no NAME section"
echo "$text" | grep -q 'vdbscatter-bake - light a density VDB' ||
  fail "man vdbscatter-bake has not its NAME line: $(echo "$text" | head -8)"
step "man vdbscatter-bake: $(echo "$text" | wc -l) lines"

# --- 5. exported symbols and SONAME --------------------------------------------------------
so=$prefix/lib/libvdbscatter.so.0
symbols=$(nm -D --defined-only "$so" | awk 'NF >= 3 { print $3 }')
offenders=$(echo "$symbols" | grep -v '^vdbs_' || true)
if [ -n "$offenders" ]; then
  echo "test_install: libvdbscatter.so.0 exports $(echo "$offenders" | wc -l) symbols outside vdbs_*:" >&2
  echo "$offenders" | head -50 | sed 's/^/  /' >&2
  fail "libvdbscatter.so.0 exports symbols that are not vdbs_*"
fi
echo "$symbols" | grep -qx vdbs_command_run || fail "libvdbscatter.so.0 does not export vdbs_command_run"
# Exactly the functions that the installed headers mark VDBS_API: no more (an internal
# function leaking out), no fewer (a declared one missing from vdbscatter/exports.map).
declared=$(grep -hv '^ *#' "$prefix"/include/vdbscatter/*.h | tr '\n' ' ' |
  grep -o 'VDBS_API [^(;]*(' | sed 's/($//; s/.*[ *]//' | sort -u)
exported=$(echo "$symbols" | sort -u)
undeclared=$(comm -13 <(echo "$declared") <(echo "$exported") | tr '\n' ' ')
unexported=$(comm -23 <(echo "$declared") <(echo "$exported") | tr '\n' ' ')
[ -z "${undeclared// /}${unexported// /}" ] ||
  fail "libvdbscatter.so.0's exports differ from the VDBS_API functions of its headers:" \
    "exported, not declared: '$undeclared'; declared, not exported: '$unexported'"
soname=$(readelf -d "$so" | sed -n 's/.*(SONAME).*\[\(.*\)\]/\1/p')
[ "$soname" = libvdbscatter.so.0 ] || fail "SONAME is '$soname', not libvdbscatter.so.0"
step "exports $(echo "$symbols" | wc -l) symbols, all vdbs_*; SONAME $soname"

# --- 6. public headers ---------------------------------------------------------------------
headers=$(cd "$prefix/include/vdbscatter" && find . -mindepth 1 | sed 's|^\./||' | sort | tr '\n' ' ')
[ "$headers" = "cancel.h export.h status.h vdbscatter.h " ] ||
  fail "include/vdbscatter holds '$headers', not exactly cancel.h export.h status.h vdbscatter.h"
printf '#include <vdbscatter/vdbscatter.h>\nint main(void) { return vdbs_version() == 0; }\n' \
  >"$work/header.c"
"$cc" -std=c11 -pedantic -Wall -Wextra -Werror -I"$prefix/include" -c -o "$work/header.o" \
  "$work/header.c" || fail "<vdbscatter/vdbscatter.h> does not compile alone as C11"
"$cxx" -std=c++17 -pedantic -Wall -Wextra -Werror -I"$prefix/include" -x c++ -c \
  -o "$work/header_cxx.o" "$work/header.c" || fail "<vdbscatter/vdbscatter.h> does not compile as C++17"

step "ok"
