// The board's clock and the `emuboard` and `time` modules.
//
// Under `-icount shift=N` QEMU's virtual clock is exactly (instructions
// executed) << N nanoseconds. The SSE-300 system counter of the
// mps3-an547 (a 64-bit up-counter, control frame at 0x58100000) is clocked
// at the board's 32 MHz sysclk and counts floor(ns / 31.25) from when it
// is enabled; with N >= 5 each instruction moves it on by at least one
// count (2**N * 0.032 >= 1.024), so the instruction count is recovered
// exactly as ceil(T * 125 / 2**(N + 2)). It is enabled first thing at
// start-up, so counts start a fixed few instructions after reset.
#include <string.h>

#include "py/mperrno.h"
#include "py/mphal.h"
#include "py/runtime.h"
#include "py/smallint.h"
#include "shared/timeutils/timeutils.h"
#include "board.h"

#define SSE_CNTCR       (*(volatile uint32_t *)0x58100000)
#define SSE_CNTCV_LO    (*(volatile uint32_t *)0x58100008)
#define SSE_CNTCV_HI    (*(volatile uint32_t *)0x5810000C)

#define TICKS_MASK      (0x3fffffff)
#define PS_PER_US       (1000000ull)

static int icount_shift = 6;

// Exclusion: nesting depth, instruction count at the outermost begin, and
// the instructions excluded so far.
static uint32_t excl_depth;
static uint64_t excl_start;
static uint64_t excl_total;

// Board time = base_ps + (charged - charged_at_cfg) * ps_per_insn.
static uint64_t ps_per_insn = 6667;
static uint64_t base_ps;
static uint64_t charged_at_cfg;

void board_init(void) {
    SSE_CNTCR = 1;  // EN
}

void board_set_icount_shift(int shift) {
    icount_shift = shift;
}

static uint64_t counter(void) {
    uint32_t hi, lo, hi2;
    do {
        hi = SSE_CNTCV_HI;
        lo = SSE_CNTCV_LO;
        hi2 = SSE_CNTCV_HI;
    } while (hi != hi2);
    return ((uint64_t)hi << 32) | lo;
}

uint64_t board_insns(void) {
    uint64_t t = counter() * 125u;
    int s = icount_shift + 2;
    return (t + ((1ull << s) - 1)) >> s;
}

static uint64_t charged_at(uint64_t now) {
    if (excl_depth) {
        now = excl_start;
    }
    return now - excl_total;
}

uint64_t board_charged_insns(void) {
    return charged_at(board_insns());
}

uint64_t board_ps(void) {
    return base_ps + (board_charged_insns() - charged_at_cfg) * ps_per_insn;
}

static inline mp_uint_t board_us(void) {
    return (mp_uint_t)(board_ps() / PS_PER_US);
}

// ---------------------------------------------------------------- emuboard
static mp_obj_t emuboard_insns(void) {
    return mp_obj_new_int_from_ull(board_insns());
}
static MP_DEFINE_CONST_FUN_OBJ_0(emuboard_insns_obj, emuboard_insns);

static mp_obj_t emuboard_charged_insns(void) {
    return mp_obj_new_int_from_ull(board_charged_insns());
}
static MP_DEFINE_CONST_FUN_OBJ_0(emuboard_charged_insns_obj, emuboard_charged_insns);

static mp_obj_t emuboard_exclude_begin(void) {
    if (excl_depth++ == 0) {
        excl_start = board_insns();
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_0(emuboard_exclude_begin_obj, emuboard_exclude_begin);

static mp_obj_t emuboard_exclude_end(void) {
    if (excl_depth == 0) {
        mp_raise_ValueError(MP_ERROR_TEXT("exclude_end without exclude_begin"));
    }
    if (--excl_depth == 0) {
        excl_total += board_insns() - excl_start;
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_0(emuboard_exclude_end_obj, emuboard_exclude_end);

static mp_obj_t emuboard_config(size_t n_args, const mp_obj_t *args) {
    if (n_args == 0) {
        return mp_obj_new_int_from_ull(ps_per_insn);
    }
    mp_int_t ps = mp_obj_get_int(args[0]);
    if (ps < 0) {
        mp_raise_ValueError(MP_ERROR_TEXT("ps_per_insn must be >= 0"));
    }
    uint64_t c = board_charged_insns();
    base_ps += (c - charged_at_cfg) * ps_per_insn;
    // On to the next whole microsecond: from here the clock's readings
    // (whole us) depend only on the instructions charged from here, not on
    // the fraction of a microsecond left by whatever ran before (a start-up
    // whose count varies would otherwise shift every later reading by 1 us
    // now and then).
    base_ps = (base_ps + PS_PER_US - 1) / PS_PER_US * PS_PER_US;
    charged_at_cfg = c;
    ps_per_insn = (uint64_t)ps;
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(emuboard_config_obj, 0, 1, emuboard_config);

static mp_obj_t emuboard_busy_us(void) {
    return MP_OBJ_NEW_SMALL_INT(board_us() & TICKS_MASK);
}
static MP_DEFINE_CONST_FUN_OBJ_0(emuboard_busy_us_obj, emuboard_busy_us);

static mp_obj_t emuboard_charge_us(mp_obj_t us_in) {
    mp_int_t us = mp_obj_get_int(us_in);
    if (us < 0) {
        mp_raise_ValueError(MP_ERROR_TEXT("us must be >= 0"));
    }
    base_ps += (uint64_t)us * PS_PER_US;
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_1(emuboard_charge_us_obj, emuboard_charge_us);

static mp_obj_t emuboard_excluding(void) {
    return MP_OBJ_NEW_SMALL_INT(excl_depth);
}
static MP_DEFINE_CONST_FUN_OBJ_0(emuboard_excluding_obj, emuboard_excluding);

static mp_obj_t emuboard_counter(void) {
    return mp_obj_new_int_from_ull(counter());
}
static MP_DEFINE_CONST_FUN_OBJ_0(emuboard_counter_obj, emuboard_counter);

static const mp_rom_map_elem_t emuboard_globals_table[] = {
    { MP_ROM_QSTR(MP_QSTR___name__), MP_ROM_QSTR(MP_QSTR_emuboard) },
    { MP_ROM_QSTR(MP_QSTR_insns), MP_ROM_PTR(&emuboard_insns_obj) },
    { MP_ROM_QSTR(MP_QSTR_charged_insns), MP_ROM_PTR(&emuboard_charged_insns_obj) },
    { MP_ROM_QSTR(MP_QSTR_exclude_begin), MP_ROM_PTR(&emuboard_exclude_begin_obj) },
    { MP_ROM_QSTR(MP_QSTR_exclude_end), MP_ROM_PTR(&emuboard_exclude_end_obj) },
    { MP_ROM_QSTR(MP_QSTR_excluding), MP_ROM_PTR(&emuboard_excluding_obj) },
    { MP_ROM_QSTR(MP_QSTR_config), MP_ROM_PTR(&emuboard_config_obj) },
    { MP_ROM_QSTR(MP_QSTR_busy_us), MP_ROM_PTR(&emuboard_busy_us_obj) },
    { MP_ROM_QSTR(MP_QSTR_charge_us), MP_ROM_PTR(&emuboard_charge_us_obj) },
    { MP_ROM_QSTR(MP_QSTR_counter), MP_ROM_PTR(&emuboard_counter_obj) },
};
static MP_DEFINE_CONST_DICT(emuboard_globals, emuboard_globals_table);

const mp_obj_module_t emuboard_module = {
    .base = { &mp_type_module },
    .globals = (mp_obj_dict_t *)&emuboard_globals,
};
MP_REGISTER_MODULE(MP_QSTR_emuboard, emuboard_module);

// ---------------------------------------------------------------- time
// Board time: the charged instructions at ps_per_insn plus charge_us().
// Clock epoch: 2021-01-01 00:00:00 UTC at reset, as an rp2 board whose
// clock nobody set.
#define EPOCH_AT_RESET (1609459200ull)

mp_uint_t mp_hal_ticks_us(void) {
    return board_us();
}

mp_uint_t mp_hal_ticks_ms(void) {
    return (mp_uint_t)(board_ps() / (PS_PER_US * 1000));
}

mp_uint_t mp_hal_ticks_cpu(void) {
    return (mp_uint_t)board_charged_insns();
}

uint64_t mp_hal_time_ns(void) {
    return EPOCH_AT_RESET * 1000000000ull + board_ps() / 1000;
}

void mp_hal_delay_us(mp_uint_t us) {
    if (excl_depth || ps_per_insn == 0) {
        base_ps += (uint64_t)us * PS_PER_US;  // no CPU time passes: charge it
        return;
    }
    uint64_t end = board_ps() + (uint64_t)us * PS_PER_US;
    while (board_ps() < end) {
        mp_handle_pending(true);
    }
}

void mp_hal_delay_ms(mp_uint_t ms) {
    mp_hal_delay_us(ms * 1000);
}

static mp_obj_t time_ticks_us(void) {
    return MP_OBJ_NEW_SMALL_INT(mp_hal_ticks_us() & TICKS_MASK);
}
static MP_DEFINE_CONST_FUN_OBJ_0(time_ticks_us_obj, time_ticks_us);

static mp_obj_t time_ticks_ms(void) {
    return MP_OBJ_NEW_SMALL_INT(mp_hal_ticks_ms() & TICKS_MASK);
}
static MP_DEFINE_CONST_FUN_OBJ_0(time_ticks_ms_obj, time_ticks_ms);

static mp_obj_t time_ticks_cpu(void) {
    return MP_OBJ_NEW_SMALL_INT(mp_hal_ticks_cpu() & TICKS_MASK);
}
static MP_DEFINE_CONST_FUN_OBJ_0(time_ticks_cpu_obj, time_ticks_cpu);

static mp_obj_t time_ticks_diff(mp_obj_t end_in, mp_obj_t start_in) {
    mp_uint_t diff = (MP_OBJ_SMALL_INT_VALUE(end_in) - MP_OBJ_SMALL_INT_VALUE(start_in)) & TICKS_MASK;
    // Signed: the half period either side.
    mp_int_t d = (mp_int_t)(diff ^ 0x20000000) - 0x20000000;
    return MP_OBJ_NEW_SMALL_INT(d);
}
static MP_DEFINE_CONST_FUN_OBJ_2(time_ticks_diff_obj, time_ticks_diff);

static mp_obj_t time_ticks_add(mp_obj_t ticks_in, mp_obj_t delta_in) {
    mp_uint_t ticks = MP_OBJ_SMALL_INT_VALUE(ticks_in);
    mp_int_t delta = mp_obj_get_int(delta_in);
    if (-0x20000000 > delta || delta >= 0x20000000) {
        mp_raise_msg(&mp_type_OverflowError, MP_ERROR_TEXT("ticks interval overflow"));
    }
    return MP_OBJ_NEW_SMALL_INT((ticks + delta) & TICKS_MASK);
}
static MP_DEFINE_CONST_FUN_OBJ_2(time_ticks_add_obj, time_ticks_add);

static mp_obj_t time_sleep(mp_obj_t s_in) {
    mp_hal_delay_us((mp_uint_t)(mp_obj_get_float(s_in) * 1000000));
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_1(time_sleep_obj, time_sleep);

static mp_obj_t time_sleep_ms(mp_obj_t ms_in) {
    mp_int_t ms = mp_obj_get_int(ms_in);
    if (ms > 0) {
        mp_hal_delay_ms(ms);
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_1(time_sleep_ms_obj, time_sleep_ms);

static mp_obj_t time_sleep_us(mp_obj_t us_in) {
    mp_int_t us = mp_obj_get_int(us_in);
    if (us > 0) {
        mp_hal_delay_us(us);
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_1(time_sleep_us_obj, time_sleep_us);

static mp_obj_t time_time(void) {
    return mp_obj_new_int_from_ull(mp_hal_time_ns() / 1000000000ull);
}
static MP_DEFINE_CONST_FUN_OBJ_0(time_time_obj, time_time);

static mp_obj_t time_time_ns(void) {
    return mp_obj_new_int_from_ull(mp_hal_time_ns());
}
static MP_DEFINE_CONST_FUN_OBJ_0(time_time_ns_obj, time_time_ns);

static mp_obj_t time_gmtime(size_t n_args, const mp_obj_t *args) {
    mp_timestamp_t t;
    if (n_args == 0 || args[0] == mp_const_none) {
        t = (mp_timestamp_t)(mp_hal_time_ns() / 1000000000ull);
    } else {
        t = (mp_timestamp_t)mp_obj_get_int(args[0]);
    }
    timeutils_struct_time_t tm;
    timeutils_seconds_since_epoch_to_struct_time(t, &tm);
    mp_obj_t tuple[8] = {
        mp_obj_new_int(tm.tm_year), mp_obj_new_int(tm.tm_mon), mp_obj_new_int(tm.tm_mday),
        mp_obj_new_int(tm.tm_hour), mp_obj_new_int(tm.tm_min), mp_obj_new_int(tm.tm_sec),
        mp_obj_new_int(tm.tm_wday), mp_obj_new_int(tm.tm_yday),
    };
    return mp_obj_new_tuple(8, tuple);
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(time_gmtime_obj, 0, 1, time_gmtime);

static mp_obj_t time_mktime(mp_obj_t tuple) {
    size_t len;
    mp_obj_t *elem;
    mp_obj_get_array(tuple, &len, &elem);
    if (len < 8 || len > 9) {
        mp_raise_TypeError(MP_ERROR_TEXT("mktime needs a tuple of length 8 or 9"));
    }
    return mp_obj_new_int_from_ull(timeutils_mktime(mp_obj_get_int(elem[0]), mp_obj_get_int(elem[1]),
        mp_obj_get_int(elem[2]), mp_obj_get_int(elem[3]), mp_obj_get_int(elem[4]), mp_obj_get_int(elem[5])));
}
static MP_DEFINE_CONST_FUN_OBJ_1(time_mktime_obj, time_mktime);

static const mp_rom_map_elem_t time_globals_table[] = {
    { MP_ROM_QSTR(MP_QSTR___name__), MP_ROM_QSTR(MP_QSTR_time) },
    { MP_ROM_QSTR(MP_QSTR_ticks_us), MP_ROM_PTR(&time_ticks_us_obj) },
    { MP_ROM_QSTR(MP_QSTR_ticks_ms), MP_ROM_PTR(&time_ticks_ms_obj) },
    { MP_ROM_QSTR(MP_QSTR_ticks_cpu), MP_ROM_PTR(&time_ticks_cpu_obj) },
    { MP_ROM_QSTR(MP_QSTR_ticks_diff), MP_ROM_PTR(&time_ticks_diff_obj) },
    { MP_ROM_QSTR(MP_QSTR_ticks_add), MP_ROM_PTR(&time_ticks_add_obj) },
    { MP_ROM_QSTR(MP_QSTR_sleep), MP_ROM_PTR(&time_sleep_obj) },
    { MP_ROM_QSTR(MP_QSTR_sleep_ms), MP_ROM_PTR(&time_sleep_ms_obj) },
    { MP_ROM_QSTR(MP_QSTR_sleep_us), MP_ROM_PTR(&time_sleep_us_obj) },
    { MP_ROM_QSTR(MP_QSTR_time), MP_ROM_PTR(&time_time_obj) },
    { MP_ROM_QSTR(MP_QSTR_time_ns), MP_ROM_PTR(&time_time_ns_obj) },
    { MP_ROM_QSTR(MP_QSTR_gmtime), MP_ROM_PTR(&time_gmtime_obj) },
    { MP_ROM_QSTR(MP_QSTR_localtime), MP_ROM_PTR(&time_gmtime_obj) },
    { MP_ROM_QSTR(MP_QSTR_mktime), MP_ROM_PTR(&time_mktime_obj) },
};
static MP_DEFINE_CONST_DICT(time_globals, time_globals_table);

const mp_obj_module_t time_module = {
    .base = { &mp_type_module },
    .globals = (mp_obj_dict_t *)&time_globals,
};
MP_REGISTER_MODULE(MP_QSTR_time, time_module);
