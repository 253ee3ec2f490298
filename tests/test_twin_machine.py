"""The twin's emulated Pico 2 ``machine`` and its virtual clock, on MicroPython."""

from __future__ import annotations

import pytest

from roboray.sim import twin
from roboray.tools.micropython import MicroPython

pytestmark = pytest.mark.micropython


@pytest.fixture(scope="module")
def board():
    mp = twin.interpreter()
    yield mp
    mp.close()


@pytest.fixture
def mp(board):
    twin.reset(board)
    board.exec("import machine, time\nfrom roboray.sim.twin.board import vclock\n"
               "from machine import Pin, I2C, PWM, UART, ADC, WDT\nt = machine.twin\n")
    return board


def raises(mp, code, match):
    with pytest.raises(Exception, match=match):
        mp.exec(code)


# ------------------------------------------------------------------ clock
def test_time_moves_only_when_the_firmware_sleeps(mp):
    mp.exec("a = time.ticks_us()\nx = sum(range(1000))\nb = time.ticks_us()\ntime.sleep_ms(7)\nc = time.ticks_ms()")
    assert mp.eval("[a, b, c]") == [0, 0, 7]
    assert mp.eval("time.time()") == 1609459200


def test_hook_sees_every_advance_after_it_happened(mp):
    mp.exec("seen = []\nvclock.set_hook(lambda dt: seen.append((dt, time.ticks_us())))\n"
            "time.sleep_us(300)\ntime.sleep_ms(2)\ntime.sleep(0.5)\nvclock.set_hook(None)")
    assert mp.eval("seen") == [[300, 300], [2000, 2300], [500000, 502300]]


def test_ticks_wrap_at_2_30_as_on_the_board(mp):
    mp.exec("vclock.reset(start_us=(1 << 30) - 10)\na = time.ticks_us()\ntime.sleep_us(25)\nb = time.ticks_us()")
    assert mp.eval("[a, b]") == [(1 << 30) - 10, 15]
    assert mp.eval("time.ticks_diff(b, a)") == 25
    assert mp.eval("time.ticks_add(a, 20)") == 10
    assert mp.alloc_bytes("time.ticks_diff(time.ticks_us(), a); time.sleep_us(10)") == 0


def test_tick_cost_lets_a_polling_loop_progress(mp):
    mp.exec("vclock.set_tick_cost_us(5)\nt0 = time.ticks_us()\n"
            "while time.ticks_diff(time.ticks_us(), t0) < 1000:\n    pass\nvclock.set_tick_cost_us(0)")
    assert 1000 <= mp.eval("time.ticks_us()") <= 1010


# -------------------------------------------------------------------- I2C
def test_bare_board_scans_empty_and_nacks_with_eio(mp):
    mp.exec("i2c = I2C(0, sda=Pin(4), scl=Pin(5), freq=400000)")
    assert mp.eval("i2c.scan()") == []
    raises(mp, "i2c.readfrom_mem(0x76, 0xA0, 2)", r"OSError: \[Errno 5\] EIO")
    raises(mp, "i2c.writeto(0x6A, b'\\x0f')", r"OSError: \[Errno 5\] EIO")


@pytest.mark.parametrize("code, match", [
    ("I2C(2)", r"I2C\(2\) doesn't exist"),
    ("I2C(0, sda=Pin(5), scl=Pin(4))", "bad SCL pin"),
    ("I2C(1, sda=Pin(4), scl=Pin(7))", "bad SDA pin"),
    ("Pin(30)", "invalid pin"),
    ("Pin('GP99')", "unknown named pin"),
    ("UART(0, tx=Pin(4))", "bad TX pin"),
    ("UART(1, rx=Pin(1))", "bad RX pin"),
    ("WDT(timeout=20000)", "timeout exceeds 16777"),
    ("PWM(Pin(10), freq=5)", "freq too small"),
    ("ADC(Pin(5))", "invalid pin"),
])
def test_wrong_arguments_fail_as_on_rp2(mp, code, match):
    raises(mp, code, match)


# ------------------------------------------------------------------- GPIO
def test_pins_pulls_outputs_and_edges(mp):
    mp.exec("up = Pin('GP14', Pin.IN, Pin.PULL_UP)\ndown = Pin(15, Pin.IN, Pin.PULL_DOWN)\n"
            "led = Pin('LED', Pin.OUT)\nedges = []\n"
            "down.irq(lambda p: edges.append(p.value()), Pin.IRQ_RISING)")
    assert mp.eval("[up.value(), down.value(), t.pin_level(25)]") == [1, 0, 0]
    mp.exec("led.on()\nt.set_pin(15, 1)\nt.set_pin(15, 0)\nt.set_pin(15, 1)\nt.set_pin(14, 0)")
    assert mp.eval("[up.value(), down.value(), t.pin_level(25), edges]") == [0, 1, 1, [1, 1]]
    mp.exec("t.set_pin(14, None)")
    assert mp.eval("up.value()") == 1


# -------------------------------------------------------------------- PWM
def test_pwm_pulses_read_back_and_slices_share_frequency(mp):
    mp.exec("a = PWM(Pin(10), freq=50, duty_ns=1500000)\nb = PWM(Pin(11), freq=50, duty_u16=32768)")
    assert mp.eval("t.pulse_ns(10)") == 1500000
    assert mp.eval("t.pulse_ns(11)") == 10000153   # half of 20 ms, to a count
    mp.exec("b.freq(100)")                          # GP10 and GP11 are slice 5
    assert mp.eval("[a.freq(), t.pulse_ns(10), t.pulse_ns(11)]") == [100, 1500000, 5000076]
    mp.exec("a.deinit()")
    assert mp.eval("t.pulse_ns(10)") == 0


# ------------------------------------------------------------------- UART
def test_uart_moves_bytes_at_the_baud_rate_and_overflows_like_a_board(mp):
    mp.exec("u = UART(0, 57600, tx=Pin(0), rx=Pin(1), rxbuf=64)\nline = t.uart(0)\nline.feed(bytes(200))")
    assert mp.eval("u.any()") == 0
    mp.exec("time.sleep_ms(5)")
    assert mp.eval("u.any()") == 28                 # 5 ms at 5760 bytes/s
    mp.exec("time.sleep_ms(100)")
    assert mp.eval("[u.any(), line.rx_dropped]") == [64, 136]
    assert mp.eval("len(u.read())") == 64
    assert mp.eval("u.read()") is None
    buf = "bytearray(8)"
    mp.exec("line.feed(b'abcdef')\ntime.sleep_ms(2)\nb = %s\nn = u.readinto(b, 3)" % buf)
    assert mp.eval("[n, bytes(b[:3])]") == [3, b"abc"]


def test_uart_writes_what_fits_and_the_far_end_takes_it_paced(mp):
    mp.exec("u = UART(0, 57600, tx=Pin(0), rx=Pin(1), txbuf=32)\nline = t.uart(0)")
    assert mp.eval("u.write(bytes(range(50)))") == 32   # timeout 0: no waiting for room
    assert mp.eval("u.write(b'x')") is None
    assert mp.eval("u.write(b'0123456789', 2, 3)") is None
    mp.exec("time.sleep_ms(2)")
    assert mp.eval("line.take()") == bytes(range(11))
    assert mp.eval("u.write(b'0123456789', 2, 3)") == 3
    mp.exec("time.sleep_ms(10)")
    assert mp.eval("line.take()") == bytes(range(11, 32)) + b"234"
    assert mp.eval("u.txdone()") is True


def test_uart_read_with_a_timeout_waits_on_the_clock(mp):
    mp.exec("u = UART(1, 115200, tx=Pin(4), rx=Pin(5), timeout=50)\nt0 = time.ticks_ms()\nr = u.read(4)")
    assert mp.eval("r") is None
    assert 50 <= mp.eval("time.ticks_diff(time.ticks_ms(), t0)") <= 51


# -------------------------------------------------------------------- ADC
def test_adc_reads_what_the_twin_sets_at_12_bits(mp):
    mp.exec("a = ADC(Pin(26))\nt.set_adc_volts(0, 1.65)")
    assert mp.eval("a.read_u16()") == (2048 << 4) | (2048 >> 8)
    assert mp.eval("ADC(4).read_u16()") == 14019
    mp.exec("t.set_adc_u16(3, 1234)")
    assert mp.eval("ADC(29).read_u16()") == 1234


# ------------------------------------------------------------ watchdog, reset
def test_watchdog_expires_unfed_and_resets_the_board(mp):
    mp.exec("w = WDT(timeout=100)\np = PWM(Pin(12), freq=50, duty_ns=1000000)\n"
            "time.sleep_ms(90)\nw.feed()\ntime.sleep_ms(90)")
    assert mp.eval("[t.wdt_expired(), t.wdt_feeds]") == [False, 1]
    mp.exec("time.sleep_ms(20)\n"
            "try:\n    try:\n        t.check_watchdog()\n    except Exception:\n        caught = 'Exception'\n"
            "except machine.BoardReset as e:\n    caught = e.cause\n")
    assert mp.eval("caught") == 3
    assert mp.eval("[machine.reset_cause(), t.pulse_ns(12), t.wdt_expired()]") == [3, 0, False]


def test_machine_reset_reports_a_watchdog_reset_as_rp2_does(mp):
    mp.exec("try:\n    machine.reset()\nexcept machine.BoardReset as e:\n    why = str(e)\n")
    assert mp.eval("[why, machine.reset_cause() == machine.WDT_RESET]") == ["machine.reset()", True]


def test_the_watchdog_register_stops_it(mp):
    mp.exec("from roboray.firmware.boards import pico2\nw = WDT(timeout=100)\n"
            "stopped = pico2.stop_watchdog(machine)\ntime.sleep_ms(500)")
    assert mp.eval("[stopped, t.wdt_expired(), machine.mem32[0x400D8000]]") == [True, False, 0]
    raises(mp, "machine.mem32[0x40000000]", "not emulated")


def test_identity_and_clock(mp):
    assert len(mp.eval("machine.unique_id()")) == 8
    assert mp.eval("machine.freq()") == 150000000


def test_machine_module_works_alone_on_the_real_clock():
    # The flashing tests load machine.py by itself as /lib/machine.py.
    with MicroPython() as m:
        m.write_file("/lib/machine.py", twin.MACHINE_PY.read_bytes())
        m.exec("import machine\ni2c = machine.I2C(0, sda=machine.Pin(4), scl=machine.Pin(5))")
        assert m.eval("i2c.scan()") == []
        assert m.eval("machine.reset_cause()") == 1
