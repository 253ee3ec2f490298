// RoboRay MicroPython: the one configuration the Pico 2 firmware, the
// emulated RP2350 and the twin's host interpreter are built with. Each
// build's own mpconfigport.h / mpconfigboard.h includes this file, so the
// three cannot drift apart.
//
// Floats live in the object word (MICROPY_OBJ_REPR_C: 1 sign, 8 exponent,
// 21 mantissa bits) and cost no heap: the estimator and controllers,
// written in Python, then allocate nothing a step, so a dive needs no
// collection in flight. Shipped this way by CircuitPython (every board),
// MicroPython's esp8266 port, Arduino's Portenta/Giga/Nicla/Opta and
// OpenMV's boards. REPR_C needs single-precision floats and 32-bit words.
#ifndef ROBORAY_MPCONFIG_ROBORAY_H
#define ROBORAY_MPCONFIG_ROBORAY_H

#define ROBORAY_BUILD (1)
#define MICROPY_OBJ_REPR (MICROPY_OBJ_REPR_C)
#define MICROPY_FLOAT_IMPL (MICROPY_FLOAT_IMPL_FLOAT)

// The flight log's RAM, kept across a watchdog reset (logram/modlogram.c):
// the ring of the default LOG_FILE_BUFSIZE (80 kB) and 128 bytes for its
// indices and check word (firmware/flightlog/logger.py). Each build's port
// configuration names the section its start-up leaves alone
// (ROBORAY_LOG_RAM_SECTION); the host build needs none.
#define ROBORAY_LOG_RAM_BYTES (80 * 1024 + 128)

#endif
