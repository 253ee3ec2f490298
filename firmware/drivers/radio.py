"""The telemetry radio on a UART: a byte pipe that never blocks the loop.

A transparent serial radio (SiK-style at 57600 baud) moves about 5.7 kB/s
each way. ``Radio`` sits between the UART (injected: ``machine.UART``)
and the MAVLink endpoint, whose transport interface it implements:

- ``read_into(buf) -> n`` hands over received bytes (0 when none), at most
  ``len(buf)``: the caller's buffer is its per-call limit, and what it does
  not take waits in the UART's own receive buffer (1024 bytes on the Pico 2,
  ``boards/pico2.py``: 180 ms of a saturated link), which is the only copy;
- ``write(buf) -> n`` hands a whole frame to the UART or, what the UART has
  no room for, queues the rest; a frame that does not fit the queue is not
  sent at all (a half frame would only be garbage on the link);
- ``service()`` (scheduler task) pushes queued bytes out as far as the UART
  accepts them: nothing to do, and no call, while the queue is empty.

Reads ask the UART only for what ``any()`` says is there (``readinto(buf,
n)``: asking for more would wait ``timeout_char`` for it), and writes hand
it whole buffers or contiguous parts of the queue (``write(buf, off, n)``),
so neither waits for a character and nothing allocates. ``bytes_per_s``:
what the line carries (the endpoint paces what it sends by it). Counters:
``rx_bytes``, ``tx_bytes``, ``tx_dropped_frames`` and ``tx_dropped_bytes``
(did not fit the queue). Bytes that arrive with the UART's buffer full are
lost in the UART, where the driver cannot count them.
"""

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

_MIN_QUEUE = const(64)


class Radio:
    """Non-blocking byte transport over ``uart`` (``baudrate``: its line rate, 8N1)."""

    def __init__(self, uart, tx_size=1024, baudrate=57600):
        if tx_size < _MIN_QUEUE:
            raise ValueError("the radio's queue must hold at least 64 bytes")
        self._uart = uart
        self._tx = bytearray(tx_size)
        self._size = tx_size
        self._tx_head = 0
        self._tx_n = 0
        #: Bytes a second the line carries (10 bits a byte: start, 8 data, stop).
        self.bytes_per_s = baudrate // 10
        self.rx_bytes = 0
        self.tx_bytes = 0
        self.tx_dropped_frames = 0
        self.tx_dropped_bytes = 0

    # ----------------------------------------------------------- receiving
    def read_into(self, buf):
        """Copy received bytes into ``buf`` (at most ``len(buf)``); how many (0 when none)."""
        uart = self._uart
        n = uart.any()
        if n <= 0:
            return 0
        if n > len(buf):
            n = len(buf)
        n = uart.readinto(buf, n)
        if not n:
            return 0
        self.rx_bytes += n
        return n

    def available(self):
        """Bytes waiting in the UART."""
        return self._uart.any()

    # -------------------------------------------------------------- sending
    def write(self, buf):
        """Send all of ``buf`` (the UART takes what it can, the queue the rest);
        its length, or 0 if it did not fit."""
        n = len(buf)
        if not self._tx_n and n <= self._size:
            # nothing queued: straight to the UART (the usual case: all of it)
            k = self._uart.write(buf)
            if k == n:
                self.tx_bytes += n
                return n
            return self._queue(buf, k if k else 0)
        return self._queue(buf, 0)

    def _queue(self, buf, k):
        # buf[k:] into the queue (the UART took buf[:k]; k > 0 only with the queue empty)
        n = len(buf)
        tx = self._tx
        size = self._size
        self.tx_bytes += k
        m = n - k
        if m > size - self._tx_n:
            self.tx_dropped_frames += 1
            self.tx_dropped_bytes += n
            return 0
        j = self._tx_head + self._tx_n
        if j >= size:
            j -= size
        if k == 0 and j + m <= size:
            tx[j:j + m] = buf  # one copy in C; no allocation for a whole buffer
        else:
            for i in range(k, n):
                if j >= size:
                    j -= size
                tx[j] = buf[i]
                j += 1
        self._tx_n += m
        if k == 0:
            self._push()
        return n

    def _push(self):
        uart = self._uart
        size = self._size
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
        """Bytes waiting to go out (in the queue, beyond what the UART holds)."""
        return self._tx_n

    def drained(self):
        """True once every byte has left the TX pin: the queue empty and the
        UART's own buffer sent (a reset drops what the UART still holds)."""
        return not self._tx_n and self._uart.txdone()

    def service(self):
        """Scheduler task: push queued bytes out."""
        if self._tx_n:
            self._push()
