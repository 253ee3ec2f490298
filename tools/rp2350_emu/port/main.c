// RoboRay emulated RP2350-class board: boot, run the script, exit QEMU.
//
// The semihosting command line (QEMU -semihosting-config arg=...) is a
// program name then words:
//   heap=BYTES      GC heap size (suffix k or m allowed); default a Pico 2's
//   main=FILE       the script to run (host path)
//   path=DIR[:DIR]  sys.path after "" (host paths)
//   icount=N        QEMU's -icount shift, so emuboard can turn time into instructions
//   romfs=ADDR      where to look for a ROMFS image (default 0x28000000, the
//                   AN547's QSPI flash, where the host has QEMU load it); when
//                   one is there it is mounted at /rom and sys.path becomes
//                   ["", "/rom", "/rom/lib", path...], as on rp2
#include <stdlib.h>
#include <string.h>

#include "genhdr/mpversion.h"
#include "py/builtin.h"
#include "py/compile.h"
#include "py/cstack.h"
#include "py/gc.h"
#include "py/lexer.h"
#include "py/mperrno.h"
#include "py/mphal.h"
#include "py/mpstate.h"
#include "py/reader.h"
#include "py/runtime.h"
#include "py/stackctrl.h"
#include "semihost.h"
#include "board.h"
#include "hostfile.h"
#include "romfs.h"

extern uint32_t _sstack, _estack, _heap_region_start, _heap_region_end;

static char cmdline[1024];

static size_t parse_size(const char *s) {
    char *end;
    unsigned long v = strtoul(s, &end, 0);
    if (*end == 'k' || *end == 'K') {
        v *= 1024;
    } else if (*end == 'm' || *end == 'M') {
        v *= 1024 * 1024;
    }
    return v;
}

static int handle_uncaught(mp_obj_t exc) {
    if (mp_obj_is_subclass_fast(MP_OBJ_FROM_PTR(mp_obj_get_type(exc)), MP_OBJ_FROM_PTR(&mp_type_SystemExit))) {
        mp_obj_t val = mp_obj_exception_get_value(exc);
        if (val == mp_const_none) {
            return 0;
        }
        mp_int_t code;
        if (mp_obj_get_int_maybe(val, &code)) {
            return (int)code & 0xff;
        }
        mp_obj_print_helper(&mp_plat_print, val, PRINT_STR);
        mp_print_str(&mp_plat_print, "\n");
        return 1;
    }
    mp_obj_print_exception(&mp_plat_print, exc);
    return 1;
}

static int run_file(const char *path) {
    nlr_buf_t nlr;
    if (nlr_push(&nlr) == 0) {
        qstr q = qstr_from_str(path);
        mp_lexer_t *lex = mp_lexer_new_from_file(q);
        mp_store_global(MP_QSTR___file__, MP_OBJ_NEW_QSTR(q));
        mp_parse_tree_t pt = mp_parse(lex, MP_PARSE_FILE_INPUT);
        mp_obj_t f = mp_compile(&pt, q, false);
        mp_call_function_0(f);
        nlr_pop();
        return 0;
    }
    return handle_uncaught(MP_OBJ_FROM_PTR(nlr.ret_val));
}

int main(void) {
    board_init();
    sh_stdout = sh_open(":tt", 3, SH_MODE_W);

    size_t heap_bytes = DEFAULT_HEAP_BYTES;
    const char *main_file = NULL;
    const char *path = NULL;
    uintptr_t romfs_addr = ROMFS_DEFAULT_ADDR;
    int n = sh_get_cmdline(cmdline, sizeof(cmdline) - 1);
    if (n < 0) {
        n = 0;
    }
    cmdline[n] = 0;
    // Split into words; the first is the program name.
    char *p = cmdline;
    bool first = true;
    while (*p) {
        while (*p == ' ') {
            *p++ = 0;
        }
        if (!*p) {
            break;
        }
        char *w = p;
        while (*p && *p != ' ') {
            p++;
        }
        if (*p) {
            *p++ = 0;
        }
        if (first) {
            first = false;
        } else if (strncmp(w, "heap=", 5) == 0) {
            heap_bytes = parse_size(w + 5);
        } else if (strncmp(w, "main=", 5) == 0) {
            main_file = w + 5;
        } else if (strncmp(w, "path=", 5) == 0) {
            path = w + 5;
        } else if (strncmp(w, "icount=", 7) == 0) {
            board_set_icount_shift(atoi(w + 7));
        } else if (strncmp(w, "romfs=", 6) == 0) {
            romfs_addr = strtoul(w + 6, NULL, 0);
        }
    }

    char *heap = (char *)&_heap_region_start;
    size_t heap_max = (char *)&_heap_region_end - heap;
    if (heap_bytes > heap_max || heap_bytes < 4096) {
        sh_write0("heap= out of range\n");
        return 2;
    }

    if (romfs_mount(romfs_addr, ROMFS_PARTITION_BYTES) < 0) {
        sh_write0("FATAL: the ROMFS image is larger than its 256 kB partition\n");
        return 134;
    }

    mp_cstack_init_with_top(&_estack, (char *)&_estack - (char *)&_sstack);
    gc_init(heap, heap + heap_bytes);
    mp_init();

    mp_sys_path = mp_obj_new_list(0, NULL);
    mp_obj_list_append(mp_sys_path, MP_OBJ_NEW_QSTR(MP_QSTR_));
    if (romfs_mounted()) {
        // rp2's order: the ROMFS before the filesystem's /lib.
        mp_obj_list_append(mp_sys_path, MP_OBJ_NEW_QSTR(MP_QSTR__slash_rom));
        mp_obj_list_append(mp_sys_path, MP_OBJ_NEW_QSTR(MP_QSTR__slash_rom_slash_lib));
    }
    if (path != NULL) {
        const char *s = path;
        while (*s) {
            const char *e = strchr(s, ':');
            size_t len = e ? (size_t)(e - s) : strlen(s);
            if (len) {
                mp_obj_list_append(mp_sys_path, mp_obj_new_str(s, len));
            }
            s += len + (e ? 1 : 0);
        }
    }
    mp_obj_list_init(MP_OBJ_TO_PTR(mp_sys_argv), 0);
    if (main_file != NULL) {
        mp_obj_list_append(mp_sys_argv, mp_obj_new_str(main_file, strlen(main_file)));
    }

    int status = 0;
    if (main_file != NULL) {
        status = run_file(main_file);
    } else {
        mp_printf(&mp_plat_print, "MicroPython %s on %s; %s with %s\n", MICROPY_GIT_TAG, MICROPY_BUILD_DATE,
            MICROPY_HW_BOARD_NAME, MICROPY_HW_MCU_NAME);
    }
    mp_deinit();
    return status;
}

// The callee-saved registers r4-r11 may hold the only pointer to an object:
// store them on the stack, then scan the stack from there to its top.
static MP_NOINLINE void collect_regs_and_stack(void) {
    uintptr_t regs[8];
    __asm__ volatile ("stmia %0, {r4-r11}" : : "r" (regs) : "memory");
    gc_collect_root((void **)regs, ((uintptr_t)MP_STATE_THREAD(stack_top) - (uintptr_t)regs) / sizeof(uintptr_t));
}

void gc_collect(void) {
    gc_collect_start();
    collect_regs_and_stack();
    gc_collect_end();
}

void nlr_jump_fail(void *val) {
    (void)val;
    sh_write0("FATAL: uncaught NLR\n");
    sh_exit(134);
}

void MP_NORETURN __fatal_error(const char *msg) {
    sh_write0("FATAL: ");
    sh_write0(msg);
    sh_write0("\n");
    sh_exit(134);
}

#ifndef NDEBUG
void MP_WEAK __assert_func(const char *file, int line, const char *func, const char *expr) {
    (void)line;
    (void)func;
    sh_write0("assertion failed: ");
    sh_write0(expr);
    sh_write0(" in ");
    sh_write0(file);
    sh_write0("\n");
    sh_exit(134);
}
#endif

// Console: semihosting writes to QEMU's stdout, no newline translation.
mp_uint_t mp_hal_stdout_tx_strn(const char *str, size_t len) {
    return sh_write(sh_stdout, str, len);
}

void mp_hal_stdout_tx_strn_cooked(const char *str, size_t len) {
    sh_write(sh_stdout, str, len);
}

void mp_hal_stdout_tx_str(const char *str) {
    sh_write(sh_stdout, str, strlen(str));
}

int mp_hal_stdin_rx_chr(void) {
    static int in = -2;
    if (in == -2) {
        in = sh_open(":tt", 3, SH_MODE_R);
    }
    unsigned char c;
    if (in < 0 || sh_read_some(in, &c, 1) != 1) {
        return 4;  // EOF: Ctrl-D
    }
    return c;
}

uintptr_t mp_hal_stdio_poll(uintptr_t poll_flags) {
    (void)poll_flags;
    return 0;
}
