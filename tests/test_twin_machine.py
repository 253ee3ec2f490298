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


def test_a_watchdog_started_after_a_long_start_up_counts_from_its_start(mp):
    # with the board's compute time charged, the clock reading that starts
    # the watchdog moves time on by the start-up's work (1.5 s here) and runs
    # the twin, which checks the watchdog: it must count from that reading,
    # not from before it (a firmware that orders its collector at start-up
    # was reset as its loop began)
    mp.exec("busy = [0]\nvclock.set_cpu(lambda: busy[0])\n"
            "vclock.set_hook(lambda dt: t.check_watchdog())\n"
            "busy[0] = 1500000\n"
            "w = WDT(timeout=1000)\nw.feed()\ntime.sleep_ms(500)\nw.feed()\n"
            "vclock.set_hook(None)\nvclock.set_cpu(None)")
    assert mp.eval("machine.reset_cause() == machine.WDT_RESET") is False
    assert mp.eval("time.ticks_ms()") >= 2000


def test_machine_reset_reports_a_watchdog_reset_as_rp2_does(mp):
    mp.exec("try:\n    machine.reset()\nexcept machine.BoardReset as e:\n    why = str(e)\n")
    assert mp.eval("[why, machine.reset_cause() == machine.WDT_RESET]") == ["machine.reset()", True]


def test_the_watchdog_register_stops_it(mp):
    mp.exec("from roboray.firmware.boards import pico2\nw = WDT(timeout=100)\n"
            "stopped = pico2.stop_watchdog(machine)\ntime.sleep_ms(500)")
    assert mp.eval("[stopped, t.wdt_expired(), machine.mem32[0x400D8000]]") == [True, False, 0]
    raises(mp, "machine.mem32[0x40000000]", "not emulated")


def test_the_watchdog_scratch_words_survive_a_watchdog_reset_not_a_power_cut(mp):
    # RP2350 datasheet 12.9.5: SCRATCH0-7 keep their words through a
    # watchdog reset and clear on a power-on; reads are signed, as rp2's
    mp.exec("from roboray.firmware.boards import pico2\ns = pico2.scratch(machine)\n"
            "s.write(bytes(range(0xF0, 0x100)))\n"
            "machine.mem32[0x400D800C + 0x2000] = 1\n"           # atomic SET alias
            "try:\n    machine.reset()\nexcept machine.BoardReset:\n    pass\n"
            "after_wdt = bytes(s.read_into(bytearray(16)))\nraw = machine.mem32[0x400D800C]\n"
            "t.power_cycle(machine.PWRON_RESET)\nafter_power = bytes(s.read_into(bytearray(16)))\n")
    assert mp.eval("after_wdt") == bytes([0xF1]) + bytes(range(0xF1, 0x100))
    assert mp.eval("raw") == 0xF3F2F1F1 - (1 << 32)
    assert mp.eval("after_power") == bytes(16)
    raises(mp, "machine.mem32[0x400D802C]", "not emulated")     # past SCRATCH7


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


# ------------------------------------------- the clock the emulation reads
def test_ticks_add_refuses_an_interval_of_half_the_period_as_rp2_does(mp):
    assert mp.eval("time.ticks_add(5, (1 << 29) - 1)") == 5 + (1 << 29) - 1
    raises(mp, "time.ticks_add(5, 1 << 29)", "OverflowError")
    raises(mp, "time.ticks_add(5, -(1 << 29))", "OverflowError")


def test_the_python_ticks_match_micropythons_own(mp):
    # CPython runs the twin on vclock's written-out ticks; MicroPython on its own.
    from roboray.sim.twin.board import vclock
    pairs = [(0, 0), (5, (1 << 30) - 3), ((1 << 30) - 3, 5), (1 << 29, 0), (0, 1 << 29), (123, 456)]
    for a, b in pairs:
        assert vclock.ticks_diff(a, b) == mp.eval("time.ticks_diff(%d, %d)" % (a, b)), (a, b)
    for t, d in [((1 << 30) - 1, 1), (0, -1), (7, (1 << 29) - 1), (7, 1 - (1 << 29))]:
        assert vclock.ticks_add(t, d) == mp.eval("time.ticks_add(%d, %d)" % (t, d)), (t, d)
    with pytest.raises(OverflowError):
        vclock.ticks_add(0, 1 << 29)


def test_a_long_sleep_reaches_the_hook_in_steps_of_at_most_a_second(mp):
    mp.exec("seen = []\nvclock.set_hook(lambda dt: seen.append(dt))\n"
            "time.sleep_us(2500000)\ntime.sleep_ms(2000)\nvclock.advance(1000001)\nvclock.set_hook(None)")
    assert mp.eval("seen") == [1000000, 1000000, 500000, 1000000, 1000000, 1000000, 1]
    assert mp.eval("[time.ticks_ms(), time.time() - 1609459200]") == [5500, 5]
    raises(mp, "vclock.advance(-1)", "time cannot go back")


def test_the_clock_state_is_what_ticks_us_returns(mp):
    mp.exec("time.sleep_us(1234)\nvclock.set_tick_cost_us(7)")
    assert mp.eval("[vclock.now_us, vclock.tick_cost_us]") == [1234, 7]
    assert mp.eval("time.ticks_us()") == 1241
    mp.exec("vclock.set_tick_cost_us(0)")
    assert mp.eval("[vclock.now_us, time.ticks_us(), time.ticks_cpu()]") == [1241, 1241, 1241]


def test_the_emulations_clock_readings_cost_what_the_firmwares_do(mp):
    # An overloaded CPU (tick cost) pays for every clock reading, the
    # peripherals' included, as before they read the clock's state directly.
    mp.exec("u = UART(0, 57600, tx=Pin(0), rx=Pin(1))\nw = WDT(timeout=1000)\n"
            "from roboray.sim.twin.board.lsm6dsox_device import LSM6DSOXDevice\n"
            "from roboray.sim.twin.board.lis3mdl_device import LIS3MDLDevice\n"
            "imu = t.attach(0, LSM6DSOXDevice())\nmag = t.attach(0, LIS3MDLDevice())\n"
            "i2c = I2C(0, sda=Pin(4), scl=Pin(5))\nb = bytearray(9)\n"
            "def cost(code):\n"
            "    t0 = vclock.now_us\n"
            "    vclock.set_tick_cost_us(5)\n"
            "    exec(code)\n"
            "    vclock.set_tick_cost_us(0)\n"
            "    return vclock.now_us - t0\n")
    assert mp.eval("cost('u.any()')") == 5
    assert mp.eval("cost('u.write(b\"x\")')") == 5
    assert mp.eval("cost('w.feed()')") == 5
    assert mp.eval("cost('t.check_watchdog()')") == 5
    assert mp.eval("cost('i2c.readfrom_mem_into(0x6A, 0x1E, b)')") == 5
    assert mp.eval("cost('i2c.readfrom_mem_into(0x1C, 0xA7, b)')") == 0   # powered down: no reading
    i2c_put = "i2c.writeto_mem(0x1C, 0x22, b'\\x00')"
    mp.exec(i2c_put)
    assert mp.eval("cost('i2c.readfrom_mem_into(0x1C, 0xA7, b)')") == 5


# ------------------------------------------- UART pacing, against a model
_UART_MODEL = """
class Model:
    # The line as the board moves it, a byte at a time: the specification
    # the emulation's counters must follow.
    def __init__(self, rxbuf, txbuf, byte_ns, cap):
        self.rxsize, self.txsize, self.byte_ns, self.cap = rxbuf, txbuf, byte_ns, cap
        self.rx, self.tx, self.wire_in, self.wire_out = [], [], [], []
        self.ci = self.co = self.dropped = self.lost = 0
        self.last = time.ticks_us()

    def pump(self):
        now = time.ticks_us()
        dt = time.ticks_diff(now, self.last)
        self.last = now
        if dt <= 0:
            return
        dt = min(dt, 100000)
        if self.wire_in:
            credit = self.ci + dt * 1000
            k = min(credit // self.byte_ns, len(self.wire_in))
            self.ci = credit - k * self.byte_ns
            for _ in range(k):
                b = self.wire_in.pop(0)
                if len(self.rx) < self.rxsize:
                    self.rx.append(b)
                else:
                    self.dropped += 1
        else:
            self.ci = 0
        if self.tx:
            credit = self.co + dt * 1000
            k = min(credit // self.byte_ns, len(self.tx))
            self.co = credit - k * self.byte_ns
            for _ in range(k):
                b = self.tx.pop(0)
                if len(self.wire_out) < self.cap:
                    self.wire_out.append(b)
                else:
                    self.lost += 1
        else:
            self.co = 0

def drive(ops):
    # the same operations on the emulated UART and on the model; what each shows
    u = UART(0, 57600, tx=Pin(0), rx=Pin(1), rxbuf=64, txbuf=32)
    line = t.uart(0)
    line.take()   # what earlier tests left on the wire; the counters go on from theirs
    m = Model(64, 32, line.byte_ns, 8192)
    m.dropped, m.lost = line.rx_dropped, line.out_lost
    src = bytearray(range(256))
    buf = bytearray(64)
    fed = 0
    got, want = [], []
    for op in ops:
        kind = op[0]
        if kind == 'sleep':
            time.sleep_us(op[1])
            continue
        if kind != 'init':
            m.pump()
        if kind == 'feed':
            data = bytes((fed + i) & 0xFF for i in range(op[1]))
            fed += op[1]
            line.feed(data)
            m.wire_in.extend(data)
        elif kind == 'any':
            got.append(u.any())
            want.append(len(m.rx))
        elif kind == 'read':
            # no more than any() says, as the radio reads: a read short of
            # its count would wait for the next character (timeout_char)
            n = u.readinto(buf, min(op[1], u.any()))
            got.append(bytes(buf[:n]) if n else None)
            k = min(op[1], len(m.rx))
            want.append(bytes(m.rx[:k]) if k else None)
            m.rx = m.rx[k:]
        elif kind == 'write':
            off, n = op[1], op[2]
            got.append(u.write(src, off, n))
            k = min(n, m.txsize - len(m.tx))
            m.tx.extend(src[off:off + k])
            want.append(k if k else None)
        elif kind == 'take':
            got.append(line.take())
            want.append(bytes(m.wire_out))
            m.wire_out = []
        elif kind == 'init':
            # a new configuration: the buffers start empty and the line's
            # clock restarts (what was on the wire meanwhile waits)
            u.init(57600, rxbuf=op[1], txbuf=op[2])
            m.rxsize, m.txsize = op[1], op[2]
            m.rx, m.tx = [], []
            m.last = time.ticks_us()
        got.append((line.rx_dropped, line.out_lost, line.pending_in(), line.tx_n))
        want.append((m.dropped, m.lost, len(m.wire_in), len(m.tx)))
    return got, want
"""


@pytest.mark.parametrize("seed", range(6))
def test_uart_pacing_moves_the_same_bytes_as_a_byte_at_a_time_line(mp, seed):
    import random
    rnd = random.Random(seed)
    ops = []
    for _ in range(400):
        r = rnd.random()
        if r < 0.3:
            ops.append(("sleep", rnd.choice([0, 1, 170, 174, 999, 5000, 20000, 150000])))
        elif r < 0.45:
            ops.append(("feed", rnd.randint(0, 120)))
        elif r < 0.6:
            ops.append(("any",))
        elif r < 0.72:
            ops.append(("read", rnd.randint(1, 64)))
        elif r < 0.9:
            off = rnd.randint(0, 200)
            ops.append(("write", off, rnd.randint(0, 40)))
        elif r < 0.98 or seed % 3 == 0:   # some runs hardly ever take: the wire overflows
            ops.append(("take",) if r < 0.97 or seed % 3 else ("sleep", 100000))
        else:
            ops.append(("init", rnd.choice([32, 64, 100]), rnd.choice([32, 48])))
    if seed % 3 == 0:   # write for seconds without taking: more than the wire holds
        ops += [("write", 0, 32), ("sleep", 6000)] * 400 + [("take",), ("any",)]
    mp.exec(_UART_MODEL)
    mp.exec("got, want = drive(%r)" % (ops,))
    got, want = mp.eval("got"), mp.eval("want")
    assert got == want
    if seed % 3 == 0:
        assert mp.eval("t.uart(0).out_lost") > 0


def test_uart_polling_allocates_nothing(mp):
    mp.exec("u = UART(0, 57600, tx=Pin(0), rx=Pin(1))\nline = t.uart(0)\nline.feed(bytes(300))\n"
            "rx = bytearray(64)\ntx = bytearray(range(100))\nline.take()")
    assert mp.alloc_bytes("time.sleep_us(10000); u.any(); u.readinto(rx, 40); u.write(tx, 30, 50)") == 0
    assert mp.alloc_bytes("time.sleep_us(100000); u.any(); u.write(tx, 0, 100)") == 0   # overflowing
