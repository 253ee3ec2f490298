// RoboRay MicroPython, host build: the unix port with the RoboRay
// configuration (../../mpconfig_roboray.h: floats in the object word,
// single precision, built 32-bit), so the twin's firmware allocates and
// collects as the board's does. Based on the unix port's "longlong" variant,
// MicroPython's own CI build of REPR_C, with the board's MPZ long ints.
#include "mpconfig_roboray.h"

// As the emulated RP2350 and the rp2 port.
#define MICROPY_CONFIG_ROM_LEVEL (MICROPY_CONFIG_ROM_LEVEL_EXTRA_FEATURES)
#define MICROPY_LONGINT_IMPL           (MICROPY_LONGINT_IMPL_MPZ)

// Enable extra Unix features (hostlink's pipes, os, time, select, ...).
#include "../mpconfigvariant_common.h"
