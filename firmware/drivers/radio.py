"""The telemetry radio on a UART: a byte pipe that never blocks the loop.

A transparent serial radio (SiK-style at 57600 baud) moves about 5.7 kB/s
each way. ``Radio`` sits between the UART (injected: ``machine.UART``)
and the MAVLink endpoint, whose transport interface it implements:

- ``service()`` (scheduler task) takes what the UART received into a ring
  buffer and pushes queued bytes out as far as the UART accepts them;
- ``read_into(buf) -> n`` hands over received bytes (0 when none);
- ``write(buf) -> n`` queues a whole frame or, when the queue lacks room,
  none of it (a half frame would only be garbage on the link).

Reads ask the UART only for what ``any()`` says is there (``readinto(buf,
n)``), and writes hand it contiguous parts of the queue (``write(buf, off,
n)``), so neither waits for a character and nothing allocates. Counters:
``rx_bytes``, ``tx_bytes``, ``rx_dropped`` (arrived with the ring full),
``tx_dropped_frames`` and ``tx_dropped_bytes`` (did not fit the queue).
"""

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

_CHUNK = const(64)


class Radio:
    """Ring-buffered, non-blocking byte transport over ``uart``."""

    def __init__(self, uart, rx_size=1024, tx_size=1024):
        if rx_size < _CHUNK or tx_size < 64:
            raise ValueError("radio buffers must hold at least 64 bytes")
        self._uart = uart
        self._rx = bytearray(rx_size)
        self._rx_head = 0
        self._rx_n = 0
        self._tx = bytearray(tx_size)
        self._tx_head = 0
        self._tx_n = 0
        self._chunk = bytearray(_CHUNK)
        self.rx_bytes = 0
        self.tx_bytes = 0
        self.rx_dropped = 0
        self.tx_dropped_frames = 0
        self.tx_dropped_bytes = 0

    # ----------------------------------------------------------- receiving
    def _pull(self, avail):
        # ``avail`` (> 0): what uart.any() said; the callers ask, so an idle
        # line costs no call here
        uart = self._uart
        chunk = self._chunk
        rx = self._rx
        size = len(rx)
        while avail > 0:
            n = uart.readinto(chunk, avail if avail < _CHUNK else _CHUNK)
            if not n:
                break
            avail -= n
            self.rx_bytes += n
            free = size - self._rx_n
            if n > free:  # the ring is full: what does not fit is lost
                self.rx_dropped += n - free
                n = free
            j = self._rx_head + self._rx_n
            if j >= size:
                j -= size
            for i in range(n):
                rx[j] = chunk[i]
                j += 1
                if j >= size:
                    j = 0
            self._rx_n += n

    def read_into(self, buf):
        """Copy received bytes into ``buf``; how many (0 when none)."""
        avail = self._uart.any()
        if avail > 0:
            self._pull(avail)
        n = self._rx_n
        if not n:
            return 0
        if n > len(buf):
            n = len(buf)
        rx = self._rx
        size = len(rx)
        h = self._rx_head
        for i in range(n):
            buf[i] = rx[h]
            h += 1
            if h >= size:
                h = 0
        self._rx_head = h
        self._rx_n -= n
        return n

    def available(self):
        """Bytes waiting in the receive ring."""
        return self._rx_n

    # -------------------------------------------------------------- sending
    def write(self, buf):
        """Queue all of ``buf`` and start sending; its length, or 0 if it did not fit."""
        n = len(buf)
        tx = self._tx
        size = len(tx)
        if n > size - self._tx_n:
            self.tx_dropped_frames += 1
            self.tx_dropped_bytes += n
            return 0
        j = self._tx_head + self._tx_n
        if j >= size:
            j -= size
        if j + n <= size:
            tx[j:j + n] = buf  # one copy in C; no allocation for a whole buffer
        else:
            for i in range(n):
                if j >= size:
                    j -= size
                tx[j] = buf[i]
                j += 1
        self._tx_n += n
        self._push()
        return n

    def _push(self):
        uart = self._uart
        size = len(self._tx)
        while self._tx_n:
            h = self._tx_head
            run = size - h if h + self._tx_n > size else self._tx_n
            n = uart.write(self._tx, h, run)
            if not n:
                return
            self.tx_bytes += n
            h += n
            self._tx_head = h - size if h >= size else h
            self._tx_n -= n
            if n < run:
                return

    def queued(self):
        """Bytes waiting to go out."""
        return self._tx_n

    def service(self):
        """Scheduler task: move bytes both ways."""
        avail = self._uart.any()
        if avail > 0:
            self._pull(avail)
        if self._tx_n:
            self._push()
