// RoboRay emulated RP2350-class board: MicroPython configuration.
//
// Mirrors what ports/rp2 (RP2350, Arm) sets where it changes speed or
// memory figures: ROM level EXTRA_FEATURES, computed goto, map lookup
// cache and load-attr fast path (EXTRA defaults, kept), stack check,
// scheduler, single-precision floats, MPZ long ints, 1-byte qstr hashes,
// uint16 GC stack entries, the Thumb native emitter and persistent-code
// loading. Built twice (build.sh): with RoboRay's configuration
// (ROBORAY_MPCONFIG: floats in the object word, REPR_C, as the Pico 2
// firmware and the twin's host build), the default; and stock (floats
// boxed on the heap, REPR_A, as rp2 ships), on which the instructions are
// calibrated against the published RP2350 timings, all measured on stock.

#include <stdint.h>
#include <alloca.h>

#if ROBORAY_MPCONFIG
#include "mpconfig_roboray.h"
// logram's region: a NOLOAD section of an547.ld that startup.c does not zero
#define ROBORAY_LOG_RAM_SECTION                 ".uninitialized_data.roboray_log"
#define MICROPY_HW_BOARD_NAME                   "RoboRay emulated RP2350 (QEMU mps3-an547), RoboRay MicroPython"
#else
#define MICROPY_HW_BOARD_NAME                   "RoboRay emulated RP2350 (QEMU mps3-an547)"
#endif
#define MICROPY_HW_MCU_NAME                     "RP2350-class Cortex-M33 (emulated)"
#define MICROPY_PY_SYS_PLATFORM                 "rp2"

#define MICROPY_CONFIG_ROM_LEVEL                (MICROPY_CONFIG_ROM_LEVEL_EXTRA_FEATURES)

// As rp2.
#define MICROPY_GC_STACK_ENTRY_TYPE             uint16_t
#define MICROPY_ALLOC_PATH_MAX                  (256)   // rp2: 128; host paths are longer
#define MICROPY_QSTR_BYTES_IN_HASH              (1)
#define MICROPY_PERSISTENT_CODE_LOAD            (1)
#define MICROPY_EMIT_THUMB                      (1)
#define MICROPY_EMIT_INLINE_THUMB               (1)
#define MICROPY_OPT_COMPUTED_GOTO               (1)
#define MICROPY_ENABLE_GC                       (1)
#define MICROPY_STACK_CHECK_MARGIN              (256)
#define MICROPY_ENABLE_EMERGENCY_EXCEPTION_BUF  (1)
#define MICROPY_LONGINT_IMPL                    (MICROPY_LONGINT_IMPL_MPZ)
#define MICROPY_FLOAT_IMPL                      (MICROPY_FLOAT_IMPL_FLOAT)
#define MICROPY_SCHEDULER_DEPTH                 (8)
#define MICROPY_SCHEDULER_STATIC_NODES          (1)
#define MICROPY_USE_INTERNAL_ERRNO              (1)
#define MICROPY_EPOCH_IS_1970                   (1)
#define MICROPY_MAKE_POINTER_CALLABLE(p)        ((void *)((mp_uint_t)(p) | 1))

// Our own file layer over semihosting (no VFS).
#define MICROPY_VFS                             (0)
#define MICROPY_READER_POSIX                    (0)
#define MICROPY_READER_VFS                      (0)
#define MICROPY_HAS_FILE_READER                 (1)
// ROMFS (as rp2 since 1.25): .mpy files read from the image's memory keep
// their bytecode and strings there. Our own /rom reader (romfs.c) stands in
// for extmod's VfsRom, so no vfs.rom_ioctl.
#define MICROPY_VFS_ROM                         (1)
#define MICROPY_VFS_ROM_IOCTL                   (0)
#define MICROPY_ENABLE_EXTERNAL_IMPORT          (1)
#define MICROPY_PY_SYS_PATH_ARGV_DEFAULTS       (0)
#define MICROPY_PY_SYS_EXIT                     (1)
#define MICROPY_PY_SYS_STDFILES                 (1)
#define MICROPY_PY_IO                           (1)
#define MICROPY_HELPER_REPL                     (0)
#define MICROPY_PY_SYS_PS1_PS2                  (0)
#define MICROPY_PY_BUILTINS_INPUT               (0)
#define MICROPY_KBD_EXCEPTION                   (1)

// Modules that live in MicroPython's extmod/ (not in the sdist): off here;
// time, os, binascii, hashlib are ours (modules.c).
#define MICROPY_PY_SELECT                       (0)
#define MICROPY_PY_TIME                         (0)
#define MICROPY_PY_ASYNCIO                      (0)
#define MICROPY_PY_UCTYPES                      (0)
#define MICROPY_PY_DEFLATE                      (0)
// json: the core prints JSON (PRINT_JSON); dumps/loads are ours (modjson.c).
#define MICROPY_PY_JSON                         (1)
#define MICROPY_PY_JSON_SEPARATORS              (0)
#define MICROPY_PY_OS                           (0)
#define MICROPY_PY_RE                           (0)
#define MICROPY_PY_HEAPQ                        (0)
#define MICROPY_PY_HASHLIB                      (0)
#define MICROPY_PY_BINASCII                     (0)
#define MICROPY_PY_RANDOM                       (0)
#define MICROPY_PY_MACHINE                      (0)
#define MICROPY_PY_PLATFORM                     (0)
#define MICROPY_PY_THREAD                       (0)

#define MP_SSIZE_MAX (0x7fffffff)
typedef intptr_t mp_int_t;
typedef uintptr_t mp_uint_t;
typedef intptr_t mp_off_t;

#define MP_STATE_PORT MP_STATE_VM
