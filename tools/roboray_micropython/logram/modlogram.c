// `logram`: the flight log's RAM, which a watchdog reset leaves as it was.
//
// SRAM keeps its contents while the chip is powered; what clears memory at
// a reset is the C start-up code, which zeroes .bss. This array sits in a
// section the start-up never touches (pico-sdk's .uninitialized_data, a
// NOLOAD section of ports/rp2/memmap_mp_rp2350.ld placed before .data; the
// emulated board's an547.ld has the same), so the ring the firmware's
// flight log writes in flight is still there after a watchdog reset
// (firmware/flightlog/logger.py). The GC heap begins after .bss, so on the
// Pico 2 it ends up that much smaller: the ring is out of the heap and out
// of every collection's scan. On the host build (the twin's interpreter)
// a watchdog reset is a new life in the same process, which keeps .bss
// anyway; the twin clears the region at a power cut.
//
// logram.region() is a bytearray over the whole region (its address and
// size are the build's: ROBORAY_LOG_RAM_BYTES in mpconfig_roboray.h).
#include "py/runtime.h"
#include "py/objarray.h"

#ifndef ROBORAY_LOG_RAM_BYTES
#error "ROBORAY_LOG_RAM_BYTES: the RoboRay configuration (mpconfig_roboray.h) sets the region's size"
#endif

#ifdef ROBORAY_LOG_RAM_SECTION
#define LOGRAM_PLACE __attribute__((section(ROBORAY_LOG_RAM_SECTION), aligned(8)))
#else
#define LOGRAM_PLACE __attribute__((aligned(8)))
#endif

static uint8_t logram_region_bytes[ROBORAY_LOG_RAM_BYTES] LOGRAM_PLACE;

static mp_obj_t logram_region(void) {
    return mp_obj_new_bytearray_by_ref(sizeof(logram_region_bytes), logram_region_bytes);
}
static MP_DEFINE_CONST_FUN_OBJ_0(logram_region_obj, logram_region);

static mp_obj_t logram_address(void) {
    return mp_obj_new_int_from_uint((uintptr_t)logram_region_bytes);
}
static MP_DEFINE_CONST_FUN_OBJ_0(logram_address_obj, logram_address);

static const mp_rom_map_elem_t logram_globals_table[] = {
    { MP_ROM_QSTR(MP_QSTR___name__), MP_ROM_QSTR(MP_QSTR_logram) },
    { MP_ROM_QSTR(MP_QSTR_region), MP_ROM_PTR(&logram_region_obj) },
    { MP_ROM_QSTR(MP_QSTR_address), MP_ROM_PTR(&logram_address_obj) },
    { MP_ROM_QSTR(MP_QSTR_SIZE), MP_ROM_INT(ROBORAY_LOG_RAM_BYTES) },
};
static MP_DEFINE_CONST_DICT(logram_globals, logram_globals_table);

const mp_obj_module_t logram_module = {
    .base = { &mp_type_module },
    .globals = (mp_obj_dict_t *)&logram_globals,
};

MP_REGISTER_MODULE(MP_QSTR_logram, logram_module);
