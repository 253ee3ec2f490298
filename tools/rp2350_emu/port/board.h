// The board's clock: instructions counted from QEMU's virtual time.
#ifndef ROBORAY_BOARD_H
#define ROBORAY_BOARD_H
#include <stdint.h>

// A Pico 2's GC heap (see README.md for the figure's source).
#define DEFAULT_HEAP_BYTES (480 * 1024)

void board_init(void);
void board_set_icount_shift(int shift);
uint64_t board_insns(void);          // since the counter started (at reset)
uint64_t board_charged_insns(void);  // outside exclude_begin/end spans
uint64_t board_ps(void);             // board time, picoseconds
#endif
