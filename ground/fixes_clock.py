"""The vehicle's clock, seen from the ground: TIMESYNC, else SYSTEM_TIME.

ATT_POS_MOCAP's ``time_usec`` is the fix's measurement time on the
vehicle's boot clock (microseconds since it started), the clock its
SYSTEM_TIME ``time_boot_ms`` and its TIMESYNC answers count: the firmware
answers a TIMESYNC request (``tc1`` 0, ``ts1`` our time) with ``tc1`` its
``time.ticks_ms()`` in nanoseconds and our ``ts1`` back
(``shared/mavlink/endpoint.py``), as ArduPilot and PX4 do. The twin's
tracker relay stamps its fixes on the same clock (``sim/twin/ground.py``).

Offset: a request sent at ``h0`` on our monotonic clock, answered at
``h1`` with the vehicle's time ``v``, says the vehicle's clock read ``v``
somewhere between ``h0`` and ``h1``; we take the middle, wrong by at most
half the round trip. Of the last ``WINDOW`` answers (one a second), the
one with the shortest round trip is used: the radio's queueing only ever
adds to a round trip. Its half is also the radio's one-way latency, which
the relay needs to make a fix arrive when it should.

Without TIMESYNC answers (a vehicle that does not answer them), the
vehicle's SYSTEM_TIME gives a bound: sent at ``time_boot_ms`` and heard
later, so of recent ones the largest ``time_boot_ms - arrival`` is the
nearest (too early by the one-way latency, which stays unknown).

A new sample more than ``JUMP_S`` away from the offset in use means the
vehicle restarted (its clock began again) or its millisecond counter
wrapped: the older samples are forgotten.
"""

from __future__ import annotations

import time
from collections import deque
from typing import Any, Optional

WINDOW = 16
REQUEST_EVERY_S = 1.0
JUMP_S = 0.5
#: A TIMESYNC request unanswered this long is forgotten.
ANSWER_WITHIN_S = 3.0


class VehicleClock:
    """Offset of the vehicle's boot clock from our ``time.monotonic()``."""

    def __init__(self) -> None:
        self._sync: deque = deque(maxlen=WINDOW)     # (offset_s, half_round_trip_s)
        self._boot: deque = deque(maxlen=WINDOW)     # offsets from SYSTEM_TIME (lower bounds)
        self._asked: dict = {}                       # the ts1 (ns) of requests not answered yet
        self._next_request = 0.0
        self.answers = 0
        self.restarts = 0

    # ---------------------------------------------------------- requests
    def due(self, now: float) -> bool:
        return now >= self._next_request

    def request(self, link: Any, now: float) -> None:
        """Send a TIMESYNC request on ``link`` (a ``ground.link.Link``)."""
        self._next_request = now + REQUEST_EVERY_S
        for k in [k for k in self._asked if now - k / 1e9 > ANSWER_WITHIN_S]:
            del self._asked[k]
        ts1 = time.monotonic_ns()       # the clock time.monotonic() reads, in ns
        self._asked[ts1] = True
        link.mav.timesync_send(0, ts1)

    # ------------------------------------------------------------ samples
    def note(self, m: Any, now: Optional[float] = None) -> None:
        """Take the vehicle's TIMESYNC answers and SYSTEM_TIMEs, heard at
        ``now`` (our monotonic time; default: now)."""
        kind = m.get_type()
        if kind not in ("TIMESYNC", "SYSTEM_TIME"):
            return
        if now is None:
            now = time.monotonic()
        if kind == "TIMESYNC":
            if m.tc1 == 0 or self._asked.pop(m.ts1, None) is None:
                return      # a request to us, or someone else's exchange
            self.answers += 1
            sent = m.ts1 / 1e9
            half = (now - sent) / 2.0
            self._add(self._sync, m.tc1 / 1e9 - (sent + half), half)
        elif not self._sync:
            # a lower bound: the vehicle's clock has moved on while it travelled
            self._add(self._boot, m.time_boot_ms / 1000.0 - now, 0.0)

    def _add(self, samples: deque, offset: float, half: float) -> None:
        current = self.offset_s()
        if current is not None and abs(offset - current) > JUMP_S + half + (self.uncertainty_s() or 0.0):
            self._sync.clear()
            self._boot.clear()
            self.restarts += 1
        samples.append((offset, half))

    # ------------------------------------------------------------ reading
    @property
    def via(self) -> Optional[str]:
        """``"TIMESYNC"``, ``"SYSTEM_TIME"`` or None: what the offset comes from."""
        return "TIMESYNC" if self._sync else "SYSTEM_TIME" if self._boot else None

    def offset_s(self) -> Optional[float]:
        """Vehicle boot time minus our monotonic time, s; None while unknown."""
        if self._sync:
            return min(self._sync, key=lambda s: s[1])[0]
        if self._boot:
            return max(s[0] for s in self._boot)
        return None

    def uncertainty_s(self) -> Optional[float]:
        """How far off the offset may be (half the best round trip); None when unbounded."""
        if self._sync:
            return min(s[1] for s in self._sync)
        return None

    def one_way_s(self) -> float:
        """The radio's latency one way, s (0 when no TIMESYNC says)."""
        u = self.uncertainty_s()
        return 0.0 if u is None else u

    def vehicle_us(self, mono_s: float) -> Optional[int]:
        """Our monotonic time ``mono_s`` on the vehicle's boot clock, us;
        None while unknown or before the vehicle started."""
        off = self.offset_s()
        if off is None:
            return None
        t = mono_s + off
        return int(round(t * 1e6)) if t >= 0.0 else None
