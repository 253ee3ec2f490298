// RoboRay emulated RP2350-class board: HAL.
#include <stdint.h>
#include "py/mpconfig.h"

static inline void mp_hal_set_interrupt_char(int c) {
    (void)c;
}
mp_uint_t mp_hal_ticks_ms(void);
mp_uint_t mp_hal_ticks_us(void);
mp_uint_t mp_hal_ticks_cpu(void);
void mp_hal_delay_ms(mp_uint_t ms);
void mp_hal_delay_us(mp_uint_t us);
uint64_t mp_hal_time_ns(void);

// No pins on this board (py/mphal.h would otherwise pull in extmod/virtpin.h).
#define mp_hal_pin_obj_t int
