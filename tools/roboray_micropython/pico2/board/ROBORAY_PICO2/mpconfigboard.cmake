# RoboRay's Pico 2: MicroPython's RPI_PICO2 board (Arm cores) with the RoboRay
# configuration (mpconfigboard.h includes mpconfig_roboray.h).
set(PICO_BOARD "pico2")
set(PICO_PLATFORM "rp2350")

# 4 MB flash: 1 MB code (of it the 256 kB ROMFS partition), 3 MB file system, as stock.
if(NOT DEFINED MICROPY_HW_FLASH_STORAGE_BYTES)
    set(MICROPY_HW_FLASH_STORAGE_BYTES 3145728)
endif()
