#!/usr/bin/env bash
# test_install.sh BUILD_DIR SOURCE_DIR CMAKE CC PYTHON: install BUILD_DIR into a temporary prefix,
# check what was installed (library with its SOVERSION, header, preload library, program, CMake
# package, ostrich.pc, the Python package, and that libostrich.so exports the public API and
# nothing else), then build tests/install/example.c against that prefix twice, with
# find_package(ostrich) and with pkg-config, run both on mjcf_models/box_plane.xml and check what
# they print; last, import the installed Python package with PYTHON and step the same box.
set -euo pipefail
build=$1 src=$2 cmake=$3 cc=$4 python=${5:-}
models=$src/mjcf_models
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
# neither build tree nor environment may supply the library: only the prefix's rpath
unset LD_LIBRARY_PATH LD_PRELOAD PKG_CONFIG_PATH CMAKE_PREFIX_PATH

prefix=$tmp/prefix
"$cmake" --install "$build" --prefix "$prefix" > "$tmp/install.log" || {
  cat "$tmp/install.log"; fail "cmake --install"; }

# files
lib=$(find "$prefix" -name 'libostrich.so' | head -1)
[ -n "$lib" ] || fail "no libostrich.so under $prefix"
libdir=$(dirname "$lib")
soname=$(objdump -p "$lib" | awk '$1 == "SONAME" {print $2}')
[[ $soname =~ ^libostrich\.so\.[0-9]+$ ]] || fail "SONAME '$soname' is not libostrich.so.N"
[ -e "$libdir/$soname" ] || fail "$soname not installed"
for f in include/ostrich/ostrich.h bin/ostrich; do
  [ -e "$prefix/$f" ] || fail "$f not installed"
done
[ -e "$libdir/libostrich_preload.so" ] || fail "libostrich_preload.so not installed"
[ -e "$libdir/cmake/ostrich/ostrichConfig.cmake" ] || fail "CMake package not installed"
[ -e "$libdir/pkgconfig/ostrich.pc" ] || fail "ostrich.pc not installed"
pydir=$prefix/lib/python3/dist-packages
for f in __init__.py physics.py rollout.py libostrich_python.so; do
  [ -e "$pydir/ostrich/$f" ] || fail "Python package: ostrich/$f not installed in $pydir"
done
# the installed program finds the installed library (its usage exits 0 with --help)
"$prefix/bin/ostrich" --help > /dev/null || fail "installed ostrich --help"

# exports: every function that ostrich.h marks OSTAPI, nothing else but the linker's own symbols
nm -D --defined-only "$lib" | awk '{print $3}' |
  grep -v -x -E '_edata|_end|__bss_start|_init|_fini' | sort > "$tmp/exported"
grep -E '^OSTAPI ' "$prefix/include/ostrich/ostrich.h" | grep -oE '\bost_[A-Za-z0-9_]+\(' |
  tr -d '(' | sort -u > "$tmp/declared"
[ -s "$tmp/declared" ] || fail "no OSTAPI declarations found in ostrich.h"
if ! diff "$tmp/declared" "$tmp/exported" > "$tmp/exports.diff"; then
  cat "$tmp/exports.diff"
  fail "libostrich.so exports differ from ostrich.h's OSTAPI functions (< declared, > exported)"
fi
echo "libostrich.so ($soname) exports $(wc -l < "$tmp/exported") symbols, all of ostrich.h"

# build the example both ways
"$cmake" -S "$src/tests/install" -B "$tmp/with_cmake" -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_C_COMPILER="$cc" > "$tmp/cmake.log" 2>&1 || { cat "$tmp/cmake.log"; fail "configure"; }
"$cmake" --build "$tmp/with_cmake" > "$tmp/build.log" 2>&1 || { cat "$tmp/build.log"; fail "build"; }
export PKG_CONFIG_PATH=$libdir/pkgconfig
flags=$(pkg-config --cflags --libs ostrich) || fail "pkg-config --cflags --libs ostrich"
echo "pkg-config: $flags"
# shellcheck disable=SC2086  # flags are words
"$cc" -std=c11 -Wall -Wextra -Werror "$src/tests/install/example.c" $flags \
  -o "$tmp/with_pkgconfig" || fail "cc example.c \$(pkg-config --cflags --libs ostrich)"

for exe in "$tmp/with_cmake/example" "$tmp/with_pkgconfig"; do
  # the program must load the installed library, not the build tree's
  ldd "$exe" | grep "libostrich.so.* => $libdir/" > /dev/null || { ldd "$exe"; fail "$exe: libostrich"; }
  out=$(OSTRICH_QUIET=1 "$exe" "$models/box_plane.xml") || fail "$exe exited $?: $out"
  echo "$(basename "$exe"): $out"
  echo "$out" >> "$tmp/outputs"
done
[ "$(sort -u "$tmp/outputs" | wc -l)" = 1 ] || fail "the two builds print different results"

# status OST_OK (0) or a warning (>= 100); 10 steps of 0.002 s
read -r status time z <<< "$(sed -E 's/^status (-?[0-9]+), time ([0-9.]+) s, box height (.*) m$/\1 \2 \3/' \
  <<< "$out")"
[[ $status == 0 || $status -ge 100 ]] || fail "status $status"
[ "$time" = 0.020 ] || fail "time $time after 10 steps of 0.002 s"
# box_plane.xml's cube rests on the floor at z = 0.1: hard contact holds it within 1e-4 m (in free
# fall it would drop g t^2 / 2 = 2e-3 m in these 0.02 s)
awk -v z="$z" 'BEGIN { exit !(z > 0.1 - 1e-4 && z < 0.1 + 1e-4) }' || fail "box height $z"

# the installed Python package: it loads the installed libostrich (its rpath), not the build's,
# and steps box_plane.xml's resting cube as the C example does
[ -n "$python" ] || fail "no python3 with numpy given (Debian: apt-get install python3-numpy)"
out=$(cd "$tmp" && OSTRICH_QUIET=1 PYTHONPATH=$pydir "$python" -c '
import sys, ostrich
physics = ostrich.Physics.from_xml_path(sys.argv[1])
status = physics.step(10)
maps = [l.split()[-1] for l in open("/proc/self/maps") if "libostrich.so" in l]
print(ostrich.__file__, status, f"{physics.data.time:.3f}", f"{physics.data.qpos[2]:.6f}",
      sorted(set(maps))[0])' "$models/box_plane.xml") || fail "python: import the installed ostrich"
echo "python: $out"
read -r pyfile status time z loaded <<< "$out"
[[ $pyfile == "$pydir/ostrich/__init__.py" ]] || fail "python imported $pyfile"
[[ $loaded == "$libdir/"* ]] || fail "python loaded $loaded, not the installed libostrich"
[[ $status == 0 && $time == 0.020 ]] || fail "python: status $status, time $time"
awk -v z="$z" 'BEGIN { exit !(z > 0.1 - 1e-4 && z < 0.1 + 1e-4) }' || fail "python: box height $z"
