"""An emulated Raspberry Pi Pico 2 ``machine`` module (rp2 port, MicroPython 1.29).

MicroPython code: the twin runs it inside the interpreter that runs the
firmware, as ``sys.modules['machine']``; the WebAssembly port has no built-in
``machine``, so the file also works alone as ``/lib/machine.py`` on the
virtual board. It imports nothing but ``time`` (the virtual clock when the
twin installed one, the real clock otherwise) and ``io``.

With nothing attached it is a bare Pico 2: ``I2C.scan()`` returns ``[]``
and any transfer raises ``OSError(EIO)`` as rp2 does on a NACK; pins read
their pulls; PWM, UART, ADC and WDT behave as the rp2 port's do (argument
checks and error messages included, so a wrong board profile fails here as
it would on the board). What the firmware sees is all it can see; the other
side of every peripheral belongs to the twin, through ``twin``:

- I2C: ``twin.attach(bus_id, device)`` puts an emulated device on a bus at
  ``device.address``. A device offers ``read(buf)``, ``write(buf)``,
  ``read_mem(memaddr, buf)`` and ``write_mem(memaddr, buf)``, which raise
  ``OSError(EIO)`` when it does not acknowledge (a NACK), ``answers()``
  (False: it would NACK) for ``scan()``, and ``power_on()`` for a power
  cycle.
- GPIO: ``twin.set_pin(pin, level)`` drives an input (None: undriven, the
  pull decides); ``twin.pin_level(pin)`` reads any pin back.
- ADC: ``twin.set_adc_volts(channel, volts)`` or ``set_adc_u16``.
- PWM: ``twin.pulse_ns(pin)`` (high time, 0 when off) and ``pwm_freq(pin)``.
- UART: ``twin.uart(uart_id)`` is the far end of the line: ``feed(data)``
  sends bytes to the board, ``take()`` returns what the board sent; both
  directions move at the baud rate against the clock, and bytes the board
  did not read in time overflow its receive buffer (``rx_dropped``).
- WDT: ``twin.wdt_expired()``; ``twin.check_watchdog()`` power-cycles and
  raises ``BoardReset`` when it expired (call it from the clock hook).
- Resets: ``machine.reset()`` and a watchdog expiry raise ``BoardReset``
  (a ``BaseException``, so the firmware's ``except Exception`` cannot
  swallow it); ``twin.power_cycle(cause)`` restarts the peripherals and
  sets what ``reset_cause()`` reports. rp2 knows only ``PWRON_RESET`` and
  ``WDT_RESET``; ``machine.reset()`` reboots through the watchdog, so the
  next ``reset_cause()`` is ``WDT_RESET`` there and here. The flight log's
  kept RAM (``logram``, on RoboRay's builds) lives through a watchdog reset
  and is cleared at a power-on, as the scratch registers are.

``mem32`` emulates the watchdog's CTRL register (its ENABLE bit) and its
eight SCRATCH registers (RP2350 datasheet 12.9.5: they keep their words
through a watchdog reset, ``machine.reset()`` included, and read 0 after a
power-on; the bootrom uses 4-7), the registers the firmware touches, with
the atomic XOR/SET/CLR aliases; a read returns what the rp2 port's does,
the word as a signed 32-bit int. Not emulated: SPI, SoftI2C, SoftSPI,
Timer, RTC, Signal, I2S, mem8/16.

The firmware polls its UART and feeds its watchdog every slot, so those
paths read the virtual clock's state directly (``vclock.now_us``, what
``ticks_us()`` returns, without a Python call) unless readings cost time.
"""

import io
import time

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

_EIO = const(5)
_NUM_PINS = const(30)        # RP2350A: GP0..GP29
_LED_PIN = const(25)
_UNSET = const(255)
_UNDRIVEN = const(2)
_SYS_FREQ = const(150000000)
_boot_freq = _SYS_FREQ       # set_boot_freq()
_WDT_MAX_MS = const(16777)   # RP2350: 24-bit counter at 1 tick/us
_PWM_MIN_HZ = const(9)       # 150 MHz / (256 * 65536) rounded up
_UART_DEFAULT_BUF = const(256)
_UART_MIN_BUF = const(32)
_UART_MAX_BUF = const(32766)
_WIRE_BUF = const(8192)      # bytes the board can send before the twin take()s them
_MAX_GAP_US = const(100000)  # longest interval paced at once (keeps ints small)

PWRON_RESET = const(1)
WDT_RESET = const(3)

#: ``time`` is the twin's virtual clock (not the host's real one).
_VCLOCK = hasattr(time, "tick_cost_us")

#: MicroPython's streams write a part of a buffer, ``write(buf, off, n)``,
#: without a view of it (a memoryview slice allocates there); CPython's
#: take the view.
try:
    io.BytesIO().write(b"", 0, 0)
    _STREAM_PARTS = True
except TypeError:
    _STREAM_PARTS = False


def _write_part(stream, buf, off, n):
    if _STREAM_PARTS:
        stream.write(buf, off, n)
    else:
        stream.write(memoryview(buf)[off:off + n])


class BoardReset(BaseException):
    """The board reset here; ``cause`` is what ``reset_cause()`` reports next
    (0 for a soft reset, which keeps the peripherals running)."""

    def __init__(self, cause, why):
        # super(), not BaseException.__init__(self, ...): on MicroPython 1.29
        # the latter makes ``except Exception`` catch the instance.
        super().__init__(why)
        self.cause = cause


def _pin_id(p):
    if isinstance(p, Pin):
        return p._id
    if isinstance(p, int):
        if 0 <= p < _NUM_PINS:
            return p
        raise ValueError("invalid pin")
    if isinstance(p, str):
        if p == "LED":
            return _LED_PIN
        if p.startswith("GP") and p[2:].isdigit() and int(p[2:]) < _NUM_PINS:
            return int(p[2:])
        raise ValueError("unknown named pin \"%s\"" % p)
    raise TypeError("expecting a Pin")


# ------------------------------------------------------------------ GPIO
class Pin:
    IN = 0
    OUT = 1
    OPEN_DRAIN = 2
    ALT = 3
    PULL_UP = 1
    PULL_DOWN = 2
    IRQ_FALLING = 4
    IRQ_RISING = 8

    def __init__(self, id, mode=-1, pull=-1, *, value=None, alt=-1):
        self._id = _pin_id(id)
        self.init(mode, pull, value=value)

    def init(self, mode=-1, pull=-1, *, value=None, alt=-1):
        t = twin
        if value is not None:
            t._latch[self._id] = 1 if value else 0
        if mode != -1:
            if mode not in (0, 1, 2, 3):
                raise ValueError("invalid pin mode: %d" % mode)
            t._mode[self._id] = mode
        if pull != -1 and pull is not None:
            if pull not in (0, 1, 2):
                raise ValueError("invalid pull value: %d" % pull)
            t._pull[self._id] = pull
        elif pull is None:
            t._pull[self._id] = 0

    def value(self, x=None):
        if x is None:
            return twin.pin_level(self._id)
        twin._latch[self._id] = 1 if x else 0
        return None

    def __call__(self, x=None):
        return self.value(x)

    def on(self):
        twin._latch[self._id] = 1

    def off(self):
        twin._latch[self._id] = 0

    def high(self):
        twin._latch[self._id] = 1

    def low(self):
        twin._latch[self._id] = 0

    def toggle(self):
        twin._latch[self._id] ^= 1

    def mode(self, mode=None):
        if mode is None:
            return twin._mode[self._id]
        self.init(mode)

    def pull(self, pull=None):
        if pull is None:
            return twin._pull[self._id]
        self.init(-1, pull)

    def irq(self, handler=None, trigger=12, hard=False):
        twin._irq[self._id] = (handler, trigger) if handler is not None else None
        return None

    def __repr__(self):
        return "Pin(GPIO%d)" % self._id


# ------------------------------------------------------------------- I2C
class I2C:
    """Hardware I2C; transfers go to the emulated device at the address."""

    def __init__(self, id=0, *, scl=None, sda=None, freq=400000, timeout=50000):
        if id not in (0, 1):
            raise ValueError("I2C(%d) doesn't exist" % id)
        if scl is not None:
            n = _pin_id(scl)
            if not (n & 1 == 1 and (n & 2) >> 1 == id):
                raise ValueError("bad SCL pin")
        if sda is not None:
            n = _pin_id(sda)
            if not (n & 1 == 0 and (n & 2) >> 1 == id):
                raise ValueError("bad SDA pin")
        self._id = id
        self._bus = twin._i2c[id]
        self.freq = freq
        self.timeout = timeout

    def _device(self, addr):
        # a device that is there raises the NACK itself when it does not answer
        dev = self._bus.get(addr)
        if dev is None:
            raise OSError(_EIO)
        return dev

    def scan(self):
        found = []
        for addr in range(0x08, 0x78):
            dev = self._bus.get(addr)
            if dev is not None and dev.answers():
                found.append(addr)
        return found

    # addrsize is keyword-only on the board; accepting it by position too
    # keeps these calls off MicroPython's slow keyword path.
    def readfrom_mem_into(self, addr, memaddr, buf, addrsize=8):
        dev = self._bus.get(addr)
        if dev is None:
            raise OSError(_EIO)
        dev.read_mem(memaddr, buf)

    def readfrom_mem(self, addr, memaddr, nbytes, addrsize=8):
        buf = bytearray(nbytes)
        self._device(addr).read_mem(memaddr, buf)
        return bytes(buf)

    def writeto_mem(self, addr, memaddr, buf, addrsize=8):
        dev = self._bus.get(addr)
        if dev is None:
            raise OSError(_EIO)
        dev.write_mem(memaddr, buf)

    def readfrom_into(self, addr, buf, stop=True):
        dev = self._bus.get(addr)
        if dev is None:
            raise OSError(_EIO)
        dev.read(buf)

    def readfrom(self, addr, nbytes, stop=True):
        buf = bytearray(nbytes)
        self._device(addr).read(buf)
        return bytes(buf)

    def writeto(self, addr, buf, stop=True):
        dev = self._bus.get(addr)
        if dev is None:
            raise OSError(_EIO)
        dev.write(buf)
        return len(buf)

    def writevto(self, addr, vector, stop=True):
        data = bytearray()
        for part in vector:
            data.extend(part)
        self._device(addr).write(data)
        return len(data)

    def __repr__(self):
        return "I2C(%d, freq=%d, timeout=%d)" % (self._id, self.freq, self.timeout)


# ------------------------------------------------------------------- PWM
class PWM:
    """One PWM channel; the two channels of a slice share its frequency."""

    def __init__(self, dest, *, freq=-1, duty_u16=-1, duty_ns=-1, invert=False):
        self._pin = _pin_id(dest)
        self._slice = (self._pin >> 1) & 7
        twin._pwm_on[self._pin] = 1
        self.init(freq=freq, duty_u16=duty_u16, duty_ns=duty_ns, invert=invert)

    def init(self, *, freq=-1, duty_u16=-1, duty_ns=-1, invert=False):
        if freq != -1:
            self.freq(freq)
        if duty_u16 != -1:
            self.duty_u16(duty_u16)
        if duty_ns != -1:
            self.duty_ns(duty_ns)
        twin._pwm_invert[self._pin] = 1 if invert else 0
        twin._pwm_on[self._pin] = 1
        twin._repulse(self._pin)

    def freq(self, value=None):
        t = twin
        if value is None:
            return t._slice_freq[self._slice]
        if value < _PWM_MIN_HZ:
            raise ValueError("freq too small")
        if value > _SYS_FREQ // 2:
            raise ValueError("freq too large")
        t._slice_freq[self._slice] = value
        for n in range(_NUM_PINS):  # every channel on the slice (rare: setup)
            if (n >> 1) & 7 == self._slice:
                t._repulse(n)
        return None

    def duty_u16(self, value=None):
        t = twin
        if value is None:
            if t._duty_is_ns[self._pin]:
                period = 1000000000 // t._slice_freq[self._slice]
                return min(65535, int(t._duty[self._pin] * 65535.0 / period))
            return t._duty[self._pin]
        if not 0 <= value <= 65535:
            raise ValueError("duty_u16 must be from 0 to 65535")
        t._duty[self._pin] = value
        t._duty_is_ns[self._pin] = 0
        t._repulse(self._pin)
        return None

    def duty_ns(self, value=None):
        if value is None:
            return twin.pulse_ns(self._pin)
        if value < 0:
            raise ValueError("duty_ns must be >= 0")
        t = twin
        n = self._pin
        t._duty[n] = value
        t._duty_is_ns[n] = 1
        # the servo driver's write every frame: _repulse() written out
        if t._pwm_on[n]:
            period = 1000000000 // t._slice_freq[self._slice]
            high = value if value < period else period
            t._pulse[n] = period - high if t._pwm_invert[n] else high
        else:
            t._pulse[n] = 0

    def deinit(self):
        twin._pwm_on[self._pin] = 0
        twin._pulse[self._pin] = 0

    def __repr__(self):
        return "<PWM slice=%d channel=%d>" % (self._slice, self._pin & 1)


# ------------------------------------------------------------------ UART
class _UartLine:
    """Both ends of one UART: the board's buffers and the wire to the twin.

    ``feed``, ``take``, ``pending_in`` and the counters are the twin's side;
    the board's ``UART`` moves bytes at the line rate whenever it is used
    (``_pump``). Bytes stay where they were put and the line rate moves
    counters, so pacing costs the same for one byte as for a thousand:

    - ``wire_in`` holds what the far end fed and the board has not read:
      first the ``rx_n`` bytes that arrived in the board's receive buffer
      (``rx_size`` bytes), then those still on the wire. Bytes that arrive
      with the buffer full are cut out of it; bytes read leave its front.
    - ``out``, a stream of ``_WIRE_BUF + tx_size`` bytes, holds what the
      board wrote and the far end has not taken: first the ``out_n`` bytes
      already on the wire (at most ``_WIRE_BUF``), then the ``tx_n`` still
      in the board's transmit buffer (``tx_size``). A write is one stream
      write of the part of the board's buffer that fits.

    The cuts are slice assignments of ``b""``, in place; nothing on the
    board's side allocates.
    """

    def __init__(self, uart_id):
        self.id = uart_id
        self.rx_size = _UART_DEFAULT_BUF
        self.rx_n = 0
        self.wire_in = bytearray()
        self.tx_size = _UART_DEFAULT_BUF
        self.tx_n = 0
        self.out = io.BytesIO(bytearray(_WIRE_BUF + _UART_DEFAULT_BUF))
        self.out_n = 0
        self._scratch = bytearray(_UART_DEFAULT_BUF)  # for a wire overflow
        self.byte_ns = 173611                    # 57600 baud, 8N1: 10 bits a byte
        self.rx_dropped = 0                      # arrived with the receive buffer full
        self.out_lost = 0                        # the twin did not take() in time
        self.open = False
        self._last = time.ticks_us()
        self._credit_in = 0
        self._credit_out = 0

    def configure(self, baudrate, frame_bits, rxbuf, txbuf):
        self.byte_ns = (frame_bits * 1000000000) // baudrate
        self.rx_size = rxbuf
        self.wire_in[0:self.rx_n] = b""  # what had arrived is gone with the old buffer
        if self.tx_size != txbuf:
            out = io.BytesIO(bytearray(_WIRE_BUF + txbuf))
            self.out.seek(0)
            out.write(self.out.read(self.out_n))
            self.out = out
            self.tx_size = txbuf
            self._scratch = bytearray(txbuf)
        self.rx_n = self.tx_n = 0
        self.open = True
        self._last = time.ticks_us()

    def _pump(self, now):
        """Move the bytes the line carried since the last call (``now``: ticks_us)."""
        dt = time.ticks_diff(now, self._last)
        self._last = now
        if dt <= 0:
            return
        if dt > _MAX_GAP_US:
            dt = _MAX_GAP_US
        bns = self.byte_ns
        waiting = len(self.wire_in) - self.rx_n
        if waiting:
            credit = self._credit_in + dt * 1000
            k = credit // bns
            if k > waiting:
                k = waiting
            self._credit_in = credit - k * bns
            room = self.rx_size - self.rx_n
            if k > room:
                # the receive buffer is full: the rest of these are lost
                self.wire_in[self.rx_size:self.rx_size + k - room] = b""
                self.rx_dropped += k - room
                k = room
            self.rx_n += k
        else:
            self._credit_in = 0
        if self.tx_n:
            credit = self._credit_out + dt * 1000
            k = credit // bns
            if k > self.tx_n:
                k = self.tx_n
            self._credit_out = credit - k * bns
            m = self.out_n
            if m + k > _WIRE_BUF:
                # the twin did not take() for seconds: what does not fit is
                # lost, and the bytes still to send close the gap
                self.out_lost += m + k - _WIRE_BUF
                out = self.out
                out.seek(m + k)
                out.readinto(self._scratch)
                out.seek(_WIRE_BUF)
                _write_part(out, self._scratch, 0, self.tx_n - k)
            self.out_n = m + k if m + k < _WIRE_BUF else _WIRE_BUF
            self.tx_n -= k
        else:
            self._credit_out = 0

    # twin side
    def feed(self, data):
        """Send ``data`` to the board; it arrives at the line rate."""
        self._pump(time.ticks_us())
        self.wire_in.extend(data)
        return len(data)

    def take(self):
        """Bytes the board has sent so far (at the line rate)."""
        self._pump(time.now_us if _VCLOCK and not time.tick_cost_us else time.ticks_us())
        n = self.out_n
        if not n:
            return b""
        out = self.out
        out.seek(0)
        sent = out.read(n)
        if self.tx_n:
            # what is still in the board's buffer moves to the front
            rest = out.read(self.tx_n)
            out.seek(0)
            out.write(rest)
        self.out_n = 0
        return sent

    def pending_in(self):
        """Bytes fed but not yet arrived at the board."""
        return len(self.wire_in) - self.rx_n

    def reset(self):
        self.rx_n = self.tx_n = 0
        self.wire_in = bytearray()
        self.open = False
        self._credit_in = 0
        self._credit_out = 0

    # board side, for UART
    def get_into(self, buf, start, count):
        """Move up to ``count`` received bytes into ``buf[start:]``; how many."""
        n = self.rx_n if self.rx_n < count else count
        src = self.wire_in
        for i in range(n):
            buf[start + i] = src[i]
        src[0:n] = b""
        self.rx_n -= n
        return n

    def put_from(self, buf, start, end):
        """Queue ``buf[start:end]`` for sending, as much as fits; how many."""
        free = self.tx_size - self.tx_n
        n = end - start if end - start < free else free
        out = self.out
        out.seek(self.out_n + self.tx_n)
        if _STREAM_PARTS:  # _write_part() written out: the firmware's write path
            out.write(buf, start, n)
        else:
            out.write(memoryview(buf)[start:start + n])
        self.tx_n += n
        return n


_UART_BAD_PIN = "bad %s pin"


class UART:
    """rp2 UART with its ring buffers; the far end is ``twin.uart(id)``."""

    INV_TX = 1
    INV_RX = 2
    CTS = 1
    RTS = 2

    def __init__(self, id, baudrate=-1, bits=-1, parity=-1, stop=-1, *, tx=None, rx=None,
                 cts=None, rts=None, timeout=-1, timeout_char=-1, invert=-1, flow=-1,
                 txbuf=-1, rxbuf=-1):
        if id not in (0, 1):
            raise ValueError("UART(%d) doesn't exist" % id)
        self._id = id
        self._line = twin._uart[id]
        self.baudrate = 115200
        self.bits = 8
        self.parity = None
        self.stop = 1
        self.timeout = 0
        self.timeout_char = 0
        self.init(baudrate, bits, parity, stop, tx=tx, rx=rx, cts=cts, rts=rts, timeout=timeout,
                  timeout_char=timeout_char, invert=invert, flow=flow, txbuf=txbuf, rxbuf=rxbuf)

    def init(self, baudrate=-1, bits=-1, parity=-1, stop=-1, *, tx=None, rx=None, cts=None,
             rts=None, timeout=-1, timeout_char=-1, invert=-1, flow=-1, txbuf=-1, rxbuf=-1):
        for pin, rem, name in ((tx, 0, "TX"), (rx, 1, "RX"), (cts, 2, "CTS"), (rts, 3, "RTS")):
            if pin is not None:
                n = _pin_id(pin)
                if not ((n & 3) == rem and (((n + 4) & 8) >> 3) == self._id):
                    raise ValueError(_UART_BAD_PIN % name)
        if baudrate > 0:
            self.baudrate = baudrate
        if bits > 0:
            if bits not in (5, 6, 7, 8):
                raise ValueError("invalid data bits")
            self.bits = bits
        if parity != -1:
            self.parity = parity
        if stop > 0:
            if stop not in (1, 2):
                raise ValueError("invalid stop bits")
            self.stop = stop
        if timeout >= 0:
            self.timeout = timeout
        if timeout_char >= 0:
            self.timeout_char = timeout_char
        # rp2: at least one whole character (13 bits to be safe)
        min_char = 13000 // self.baudrate + 1
        if self.timeout_char < min_char:
            self.timeout_char = min_char
        sizes = []
        for size, name in ((rxbuf, "rxbuf"), (txbuf, "txbuf")):
            if size <= 0:
                size = _UART_DEFAULT_BUF
            elif size < _UART_MIN_BUF:
                size = _UART_MIN_BUF
            elif size > _UART_MAX_BUF:
                raise ValueError("%s too large" % name)
            sizes.append(size)
        frame = 1 + self.bits + (0 if self.parity is None else 1) + self.stop
        self._line.configure(self.baudrate, frame, sizes[0], sizes[1])

    def deinit(self):
        self._line.reset()

    def any(self):
        line = self._line
        # The firmware polls this every slot: the clock read without a call,
        # and no pump when it has not moved since the last one.
        now = time.now_us if _VCLOCK and not time.tick_cost_us else time.ticks_us()
        if now != line._last:
            line._pump(now)
        return line.rx_n

    def _wait(self, us, want_rx):
        # Blocking as the board blocks: sleep in byte times, so the clock
        # (and, in the twin, the world) moves while the firmware waits.
        line = self._line
        step = line.byte_ns // 1000 + 1
        waited = 0
        while waited < us:
            time.sleep_us(step)
            waited += step
            line._pump(time.ticks_us())
            if (line.rx_n if want_rx else line.tx_size - line.tx_n):
                return True
        return False

    def readinto(self, buf, nbytes=-1):
        line = self._line
        line._pump(time.ticks_us())
        n = len(buf) if nbytes < 0 or nbytes > len(buf) else nbytes
        i = line.get_into(buf, 0, n)
        while i < n:
            wait = self.timeout if i == 0 else self.timeout_char
            if wait <= 0 or not self._wait(wait * 1000, True):
                break
            i += line.get_into(buf, i, n - i)
        return i if i else None

    def read(self, nbytes=-1):
        line = self._line
        line._pump(time.ticks_us())
        if nbytes < 0:
            nbytes = line.rx_n if line.rx_n else 1
        buf = bytearray(nbytes)
        n = self.readinto(buf)
        if n is None:
            return None
        return bytes(buf) if n == nbytes else bytes(buf[:n])

    def readline(self):
        out = bytearray()
        b = bytearray(1)
        while self.readinto(b) == 1:
            out.append(b[0])
            if b[0] == 10:
                break
        return bytes(out) if out else None

    def write(self, buf, off=0, sz=-1):
        line = self._line
        line._pump(time.now_us if _VCLOCK and not time.tick_cost_us else time.ticks_us())
        end = len(buf) if sz < 0 or off + sz > len(buf) else off + sz
        i = off + line.put_from(buf, off, end)
        while i < end:
            if self.timeout <= 0 or not self._wait(self.timeout * 1000, False):
                break
            i += line.put_from(buf, i, end)
        n = i - off
        return n if n else None

    def txdone(self):
        line = self._line
        line._pump(time.ticks_us())
        return line.tx_n == 0

    def flush(self):
        line = self._line
        while not self.txdone():
            time.sleep_us(line.byte_ns // 1000 + 1)

    def sendbreak(self):
        time.sleep_us(13000000 // self.baudrate + 1)

    def __repr__(self):
        return "UART(%d, baudrate=%d, bits=%d, parity=%s, stop=%d, txbuf=%d, rxbuf=%d, timeout=%d, timeout_char=%d)" % (
            self._id, self.baudrate, self.bits, self.parity, self.stop, self._line.tx_size,
            self._line.rx_size, self.timeout, self.timeout_char)


# ------------------------------------------------------------------- ADC
class ADC:
    CORE_TEMP = 4

    def __init__(self, pin):
        if isinstance(pin, Pin) or (isinstance(pin, int) and pin >= 26):
            n = _pin_id(pin)
            if not 26 <= n <= 29:
                raise ValueError("invalid pin")
            self._ch = n - 26
        elif isinstance(pin, int) and 0 <= pin <= 4:
            self._ch = pin
        else:
            raise ValueError("invalid channel")

    def read_u16(self):
        return twin._adc[self._ch]


# ------------------------------------------------------------------- WDT
class WDT:
    def __init__(self, id=0, timeout=5000):
        if id != 0:
            raise ValueError("WDT(%d) doesn't exist" % id)
        if timeout > _WDT_MAX_MS:
            raise ValueError("timeout exceeds %d" % _WDT_MAX_MS)
        twin._wdt_start(timeout)

    def feed(self):
        t = twin
        t.wdt_feeds += 1
        t._wdt_last = time.now_us if _VCLOCK and not time.tick_cost_us else time.ticks_us()


# ---------------------------------------------------------------- mem32
_WATCHDOG_CTRL = 0x400D8000   # RP2350 WATCHDOG CTRL; +0x1000 XOR, +0x2000 SET, +0x3000 CLR
_WATCHDOG_ENABLE = 0x40000000
_WATCHDOG_SCRATCH0 = 0x400D800C   # SCRATCH0..7 at 0x0c..0x28
_SCRATCH_WORDS = const(8)


class _Mem32:
    """Word access to the RP2350's registers. The watchdog's CTRL (its
    ENABLE bit) and SCRATCH0-7 are emulated, through the normal and the
    atomic aliases; any other address raises, as a hard fault would stop a
    board."""

    def _where(self, addr):
        """(register: -1 for CTRL, else the scratch index; alias offset)."""
        alias = (addr - _WATCHDOG_CTRL) & 0x3000
        off = addr - _WATCHDOG_CTRL - alias
        if 0 <= alias <= 0x3000 and addr >= _WATCHDOG_CTRL:
            if off == 0:
                return -1, alias
            k = (off - 0x0C) >> 2
            if off & 3 == 0 and 0 <= k < _SCRATCH_WORDS:
                return k, alias
        raise ValueError("mem32[0x%08X]: register not emulated" % addr)

    def __getitem__(self, addr):
        reg, _ = self._where(addr)
        if reg < 0:
            return _WATCHDOG_ENABLE if twin.wdt_timeout_ms else 0
        v = twin.scratch[reg]
        # the rp2 port returns mp_obj_new_int() of the uint32: signed
        return v - 0x100000000 if v & 0x80000000 else v

    def __setitem__(self, addr, value):
        reg, alias = self._where(addr)
        value &= 0xFFFFFFFF
        if reg >= 0:
            s = twin.scratch
            old = s[reg]
            if alias == 0:
                s[reg] = value
            elif alias == 0x1000:
                s[reg] = old ^ value
            elif alias == 0x2000:
                s[reg] = old | value
            else:
                s[reg] = old & ~value
            return
        bit = bool(value & _WATCHDOG_ENABLE)
        on = bool(twin.wdt_timeout_ms)
        if alias == 0:
            on = bit
        elif alias == 0x1000:
            on = on != bit
        elif alias == 0x2000:
            on = on or bit
        else:
            on = on and not bit
        twin._wdt_enable(on)


mem32 = _Mem32()


# -------------------------------------------------------- module functions
def reset():
    # rp2 reboots through the watchdog: the next reset_cause() is WDT_RESET.
    twin.power_cycle(WDT_RESET)
    raise BoardReset(WDT_RESET, "machine.reset()")


def soft_reset():
    raise BoardReset(0, "machine.soft_reset()")


def reset_cause():
    return twin.reset_cause


def bootloader(value=None):
    twin.power_cycle(PWRON_RESET)
    raise BoardReset(PWRON_RESET, "machine.bootloader()")


def unique_id():
    return twin.unique_id


def freq(hz=None):
    if hz is None:
        return twin.sys_freq
    twin.sys_freq = hz
    return None


def set_boot_freq(hz):
    """The CPU clock the board comes up at, from now and after every reset
    (the twin's ``--cpu-mhz``: a board clocked other than the Pico 2's
    150 MHz; ``freq()`` reports it, as the chip's does)."""
    global _boot_freq
    _boot_freq = int(hz)
    twin.sys_freq = _boot_freq


def idle():
    # Returns at the next interrupt: the 1 kHz tick at the latest.
    time.sleep_us(1000)


def lightsleep(time_ms=None):
    time.sleep_ms(1 if time_ms is None else time_ms)


def deepsleep(time_ms=None):
    lightsleep(time_ms)
    reset()


def disable_irq():
    return 0


def enable_irq(state=0):
    return None


def time_pulse_us(pin, pulse_level, timeout_us=1000000):
    # Nothing on a pin ever pulses by itself: wait the time-out, report none.
    time.sleep_us(timeout_us)
    return -2


def _clear_log_ram():
    """A power-on: the RAM RoboRay's build keeps across a watchdog reset for
    the flight log (``logram``, firmware/boards/pico2.py ``log_ram``) lost
    what it held. On the twin's interpreters that have it (roboray-unix, the
    emulated RP2350's RoboRay image) a reset is a new life in the same
    process, which keeps it; here it is zeroed (the chip's cells settle to
    whatever they settle to: the logger's check refuses either)."""
    try:
        import logram
    except ImportError:
        return      # stock builds: the ring is in the heap
    r = logram.region()
    n = len(r)
    z = bytes(64)
    i = 0
    while i + 64 <= n:
        r[i:i + 64] = z
        i += 64
    while i < n:
        r[i] = 0
        i += 1


# ---------------------------------------------------------------- the twin
class _Twin:
    """The outside of the board; see the module docstring."""

    def __init__(self):
        self._i2c = ({}, {})
        self._uart = (_UartLine(0), _UartLine(1))
        self._mode = bytearray(_NUM_PINS)
        self._pull = bytearray(_NUM_PINS)
        self._latch = bytearray(_NUM_PINS)
        self._drive = bytearray(_NUM_PINS)
        self._irq = [None] * _NUM_PINS
        self._adc = [0, 0, 0, 0, 14019]   # channel 4: the die at 27 C (0.706 V)
        self._slice_freq = [1000] * 8
        self._duty = [0] * _NUM_PINS
        self._duty_is_ns = bytearray(_NUM_PINS)
        self._pwm_on = bytearray(_NUM_PINS)
        self._pwm_invert = bytearray(_NUM_PINS)
        #: pulse_ns() of each pin, kept current by every PWM write (the twin
        #: reads four a frame: a list lookup, not the arithmetic each time).
        self._pulse = [0] * _NUM_PINS
        self.unique_id = b"\xe6\x61\x41\x04\x03\x2b\x7a\x2e"
        #: The watchdog's SCRATCH0-7 words (unsigned).
        self.scratch = [0] * _SCRATCH_WORDS
        self.clear()

    def clear(self):
        """A bare board after power-on: no devices, nothing driven."""
        for bus in self._i2c:
            for addr in list(bus):
                del bus[addr]
        for i in range(_NUM_PINS):
            self._drive[i] = _UNDRIVEN
        for ch in range(4):
            self._adc[ch] = 0
        self.power_cycle(PWRON_RESET)

    def power_cycle(self, cause=PWRON_RESET):
        """Restart the board's peripherals; ``reset_cause()`` becomes ``cause``.

        The world outside (twin-driven pins, ADC inputs, attached devices)
        stays; devices restart, and the watchdog's scratch registers clear,
        only on a power-on reset, since a watchdog reset does not cut the
        sensors' supply nor the chip's.
        """
        for i in range(_NUM_PINS):
            self._mode[i] = _UNSET
            self._pull[i] = 0
            self._latch[i] = 0
            self._irq[i] = None
            self._duty[i] = 0
            self._duty_is_ns[i] = 0
            self._pwm_on[i] = 0
            self._pwm_invert[i] = 0
            self._pulse[i] = 0
        for s in range(8):
            self._slice_freq[s] = 1000
        for line in self._uart:
            line.reset()
        self.wdt_timeout_ms = 0
        self._wdt_saved = 0
        self.wdt_feeds = 0
        self._wdt_last = 0
        self.reset_cause = cause
        self.sys_freq = _boot_freq
        if cause == PWRON_RESET:
            # the scratch registers live through a watchdog reset only
            for i in range(_SCRATCH_WORDS):
                self.scratch[i] = 0
            _clear_log_ram()
            for bus in self._i2c:
                for dev in bus.values():
                    if hasattr(dev, "power_on"):
                        dev.power_on()

    # I2C
    def attach(self, bus_id, device):
        """Put an emulated device on I2C bus ``bus_id`` at ``device.address``."""
        bus = self._i2c[bus_id]
        if device.address in bus and bus[device.address] is not device:
            raise ValueError("I2C%d address 0x%02X is already taken" % (bus_id, device.address))
        bus[device.address] = device
        return device

    def detach(self, bus_id, address):
        self._i2c[bus_id].pop(address, None)

    def devices(self, bus_id):
        return dict(self._i2c[bus_id])

    # GPIO
    def set_pin(self, pin, level):
        """Drive an input from outside (None: release it to its pull)."""
        n = _pin_id(pin)
        before = self.pin_level(n)
        self._drive[n] = _UNDRIVEN if level is None else (1 if level else 0)
        after = self.pin_level(n)
        irq = self._irq[n]
        if irq is not None and before != after:
            handler, trigger = irq
            if (after and trigger & Pin.IRQ_RISING) or (not after and trigger & Pin.IRQ_FALLING):
                handler(Pin(n))

    def pin_level(self, pin):
        """The level on a pin as the board and the outside both see it."""
        n = pin if isinstance(pin, int) and 0 <= pin < _NUM_PINS else _pin_id(pin)
        mode = self._mode[n]
        if mode == 1:  # push-pull output drives the pad
            return self._latch[n]
        if mode == 2 and self._latch[n] == 0:  # open drain pulls low
            return 0
        d = self._drive[n]
        if d != _UNDRIVEN:
            return d
        return 1 if self._pull[n] == 1 else 0

    # ADC
    def set_adc_u16(self, channel, value):
        if not 0 <= value <= 65535:
            raise ValueError("ADC value %r outside 0..65535" % (value,))
        self._adc[channel] = value

    def set_adc_volts(self, channel, volts, vref=3.3):
        """Voltage at the ADC pin, quantised as the RP2350's 12-bit ADC reads it."""
        raw = int(volts / vref * 4095 + 0.5)
        raw = 0 if raw < 0 else (4095 if raw > 4095 else raw)
        # MicroPython scales the 12-bit sample to 16 bits this way.
        self._adc[channel] = (raw << 4) | (raw >> 8)

    # PWM
    def pwm_freq(self, pin):
        n = _pin_id(pin)
        return self._slice_freq[(n >> 1) & 7] if self._pwm_on[n] else 0

    def pulse_ns(self, pin):
        """High time of the PWM output on ``pin`` in ns (0 when off)."""
        # the twin asks by number every frame: no _pin_id() call for that
        n = pin if isinstance(pin, int) and 0 <= pin < _NUM_PINS else _pin_id(pin)
        return self._pulse[n]

    def _repulse(self, n):
        # pulse_ns() of pin n from its PWM state, after a change to it
        if not self._pwm_on[n]:
            self._pulse[n] = 0
            return
        period = 1000000000 // self._slice_freq[(n >> 1) & 7]
        if self._duty_is_ns[n]:
            high = self._duty[n] if self._duty[n] < period else period
        else:
            high = int(self._duty[n] * period / 65535.0 + 0.5)
        self._pulse[n] = period - high if self._pwm_invert[n] else high

    # UART
    def uart(self, uart_id):
        """The far end of UART ``uart_id``: ``feed(data)``, ``take()``."""
        return self._uart[uart_id]

    # WDT
    def _wdt_start(self, timeout_ms):
        # the clock read first: reading it runs the twin, which checks a
        # running watchdog against its last feed
        now = time.ticks_us()
        self.wdt_timeout_ms = timeout_ms
        self._wdt_last = now

    def _wdt_enable(self, on):
        if on and not self.wdt_timeout_ms and self._wdt_saved:
            now = time.ticks_us()
            self.wdt_timeout_ms = self._wdt_saved
            self._wdt_last = now
        elif not on and self.wdt_timeout_ms:
            self._wdt_saved = self.wdt_timeout_ms
            self.wdt_timeout_ms = 0

    def wdt_expired(self):
        """True when the watchdog runs and was not fed within its time-out."""
        if not self.wdt_timeout_ms:
            return False
        return time.ticks_diff(time.ticks_us(), self._wdt_last) > self.wdt_timeout_ms * 1000

    def check_watchdog(self):
        """Reset the board (raise ``BoardReset``) if the watchdog expired."""
        # wdt_expired() written out: the twin asks on every advance of time
        if not self.wdt_timeout_ms:
            return
        now = time.now_us if _VCLOCK and not time.tick_cost_us else time.ticks_us()
        if time.ticks_diff(now, self._wdt_last) > self.wdt_timeout_ms * 1000:
            self.power_cycle(WDT_RESET)
            raise BoardReset(WDT_RESET, "watchdog expired")


#: The other side of every peripheral: what the twin drives and reads.
twin = _Twin()
