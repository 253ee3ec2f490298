// py/modsys.c includes this MicroPython extmod header (not in the sdist) for
// compiler/platform names used only when a port names no board; this port
// names its board (MICROPY_HW_BOARD_NAME), so nothing is needed here.
