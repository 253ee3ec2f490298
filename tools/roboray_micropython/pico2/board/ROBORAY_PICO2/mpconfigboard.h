// RoboRay's Pico 2: MicroPython's RPI_PICO2 board (ports/rp2/boards/RPI_PICO2)
// with the RoboRay configuration, the one the emulated RP2350 and the twin's
// host interpreter include too (tools/roboray_micropython/mpconfig_roboray.h;
// build.sh copies it next to this file).

// The board reports this build as itself: os.uname().machine reads
// "RoboRay Pico 2 with RP2350" and sys.implementation._build
// "ROBORAY_PICO2" (the board folder's name), which roboray-flash checks.
#define MICROPY_HW_BOARD_NAME                   "RoboRay Pico 2"

// The ROMFS partition `roboray-flash deploy` writes the board code to
// (mounted at /rom): .mpy files imported from it run in place from flash, so
// the firmware's live heap and each collection are smaller
// (docs/design/board-time.md: 180 -> 106 kB live, 42.6 -> 31.2 ms a
// collection). Stock RPI_PICO2 builds of this MicroPython have none
// (ports/rp2/mpconfigport.h: MICROPY_HW_ROMFS_BYTES 0). 256 kB holds the
// board code's image several times; rp2_flash.c puts it at the top of the
// code space, below the file system, so the 3 MB file system stays as stock.
#define MICROPY_HW_ROMFS_BYTES                  (256 * 1024)

#include "mpconfig_roboray.h"

// logram's region (../logram, a user C module build.sh adds): pico-sdk's
// .uninitialized_data section (ports/rp2/memmap_mp_rp2350.ld: NOLOAD, before
// .data; crt0 zeroes .bss only), which a watchdog reset leaves as it was.
// The GC heap starts after .bss, so it is ROBORAY_LOG_RAM_BYTES smaller.
#define ROBORAY_LOG_RAM_SECTION                 ".uninitialized_data.roboray_log"
