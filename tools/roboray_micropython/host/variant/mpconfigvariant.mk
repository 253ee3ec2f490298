# RoboRay MicroPython, host build (tools/roboray_micropython/host/build.sh).

# REPR_C needs 32-bit words, as on the RP2350 (Debian's gcc-multilib).
MICROPY_FORCE_32BIT := 1

# Linked statically: a machine without 32-bit libraries runs it as it is.
LDFLAGS_EXTRA += -static

# What needs libraries or sources outside MicroPython's py/, shared/,
# extmod/ and lib/{crypto-algorithms,uzlib,re1.5}: off (the twin uses none).
MICROPY_PY_FFI := 0
MICROPY_PY_BTREE := 0
MICROPY_PY_SSL := 0
MICROPY_SSL_MBEDTLS := 0
MICROPY_PY_SOCKET := 0
MICROPY_PY_THREAD := 0
MICROPY_VFS_FAT := 0
MICROPY_VFS_LFS1 := 0
MICROPY_VFS_LFS2 := 0
MICROPY_USE_READLINE := 1

# No frozen modules (no mpy-cross needed to build).
FROZEN_MANIFEST :=
