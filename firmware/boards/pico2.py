"""Raspberry Pi Pico 2 (RP2350, MicroPython rp2 port): the default board.

Wiring, as the functions below build it:

=============  ==========================================================
I2C0           SDA GP4, SCL GP5, 400 kHz: MS5837-30BA (0x76), LSM6DSOX
               (0x6A) and LIS3MDL (0x1C) (Adafruit's 9-DoF board)
servos         PWM 50 Hz on GP10, GP11, GP12, GP13: wings 1..4
radio          UART0 TX GP0, RX GP1, 57600 baud
battery        ADC0 (GP26) through a divider (BATT_VOLT_MULT, 3.0 for 2S)
leak probe     GP15, digital input, active high, pulled down
=============  ==========================================================

Every function takes the ``machine`` module, so the twin's emulated one
serves as well as the board's.
"""

from roboray.firmware.drivers.scratch import Scratch

NAME = "pico2"
DESCRIPTION = "Raspberry Pi Pico 2 (RP2350)"

I2C_ID = 0
I2C_SDA = 4
I2C_SCL = 5
I2C_FREQ = 400000
MS5837_ADDR = 0x76
LSM6DSOX_ADDR = 0x6A
LIS3MDL_ADDR = 0x1C

SERVO_PINS = (10, 11, 12, 13)   # wings 1..4
SERVO_FREQ = 50

UART_ID = 0
UART_TX = 0
UART_RX = 1
UART_BAUD = 57600
UART_RXBUF = 1024               # 180 ms of a saturated link: rides out a long cycle
UART_TXBUF = 1024

BATTERY_ADC_PIN = 26
ADC_VREF = 3.3

LEAK_PIN = 15
LEAK_ACTIVE_HIGH = True


def i2c_name():
    """The sensor bus as a person finds it on the board."""
    return "I2C%d (SDA GP%d, SCL GP%d)" % (I2C_ID, I2C_SDA, I2C_SCL)


def i2c(machine):
    return machine.I2C(I2C_ID, sda=machine.Pin(I2C_SDA), scl=machine.Pin(I2C_SCL), freq=I2C_FREQ)


def servo_pwms(machine):
    """One PWM channel per wing, 50 Hz, no pulse yet."""
    return [machine.PWM(machine.Pin(p), freq=SERVO_FREQ, duty_ns=0) for p in SERVO_PINS]


def uart(machine, baudrate=UART_BAUD):
    return machine.UART(UART_ID, baudrate=baudrate, tx=machine.Pin(UART_TX), rx=machine.Pin(UART_RX),
                        rxbuf=UART_RXBUF, txbuf=UART_TXBUF, timeout=0)


def battery_adc(machine):
    return machine.ADC(machine.Pin(BATTERY_ADC_PIN))


def leak_pin(machine):
    return machine.Pin(LEAK_PIN, machine.Pin.IN, machine.Pin.PULL_DOWN)


# RP2350 WATCHDOG block (datasheet section 12.9): CTRL at the base, bit 30
# ENABLE; writing the atomic-clear alias (+0x3000) clears bits without a
# read-modify-write.
_WATCHDOG_CTRL = 0x400D8000
_ATOMIC_CLEAR = 0x3000
_WATCHDOG_ENABLE = 1 << 30
# its SCRATCH0 (offset 0x0c): SCRATCH0-3 are the application's, 4-7 the bootrom's
_WATCHDOG_SCRATCH0 = 0x400D800C


def stop_watchdog(machine):
    """Stop the hardware watchdog, which ``machine.WDT`` cannot do.

    Used when someone interrupts the application at the USB REPL (Ctrl-C,
    the flashing tool): the running watchdog would otherwise reset the board
    under them a second later. False when the port has no ``mem32``.
    """
    mem32 = getattr(machine, "mem32", None)
    if mem32 is None:
        return False
    mem32[_WATCHDOG_CTRL + _ATOMIC_CLEAR] = _WATCHDOG_ENABLE
    return True


def scratch(machine):
    """The watchdog's scratch words SCRATCH0-3 (``drivers/scratch.py``): they
    survive a watchdog reset. None when the port has no ``mem32``."""
    mem32 = getattr(machine, "mem32", None)
    if mem32 is None:
        return None
    return Scratch(mem32, _WATCHDOG_SCRATCH0)


def log_ram(machine=None):
    """The RAM RoboRay's MicroPython keeps across a watchdog reset for the
    flight log's ring (a ``bytearray`` over it), or None on a build without
    one (stock MicroPython: the ring is then in the heap).

    The build places it (``logram``, a C module of
    ``tools/roboray_micropython``: pico-sdk's ``.uninitialized_data``
    section, which the C start-up does not zero, and the GC heap ends that
    much early); its address and size are the build's, not this file's."""
    try:
        import logram
    except ImportError:
        return None
    return logram.region()
