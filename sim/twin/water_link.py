"""The twin's radio link through water: frames lost by depth, RADIO_STATUS.

``WaterLink`` holds a ``sim/radio`` ``Channel`` for the run's radio and
water and, once a servo frame (20 ms), moves it to the depth of the
vehicle's antenna (the dome's top, ``World.antenna_depth``). What each end
sent in that frame crosses the air whole or not at all (``crosses``): the
fade is the same for everything within 20 ms, and a radio's packet carries
a few frames at once, so a lost packet takes them together (and may cut a
frame it began, as a real link does).

The link is *lost* when nothing has crossed for ``LOST_AFTER_S`` (1 s, the
SiK radios' and a ground station's own notion of a link gone: heartbeats
are a second apart); it is *regained* at the first frame that crosses
again. ``events`` keeps both with the antenna's depth: for a loss, the
depth at the last frame that crossed, where the link really ended.

RADIO_STATUS. A SiK radio sends one a second to the device on its serial
port (SiK firmware, ``MAVLink_report``: system 51 ``'3'``, component 68
``'D'``): ``rssi`` its own received level, ``remrssi`` the other radio's (as
that one reported it over the air), ``noise``/``remnoise`` the noise
floors, ``rxerrors`` packets it lost, ``txbuf`` the free room in its send
buffer (percent). Levels are in SiK's units, about 1.9 a dB above -127 dBm
(MAVLink's RADIO_STATUS: "scale as approx 2x dB on SiK radios"; SiK's
documentation: dBm = rssi / 1.9 - 127). The twin sends one to the ground
(the ground's radio) and one to the vehicle (its own) each second, for the
SiK radios only: the HC-12 is a transparent serial link and sends nothing
of its own.
"""

from __future__ import annotations

import logging
import os
from typing import Optional

import numpy as np

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from roboray.sim.radio import link as link_mod  # noqa: E402

log = logging.getLogger("roboray.sim.twin")

LOST_AFTER_S = 1.0
SIK_SYSID = 51      #: '3'
SIK_COMPID = 68     #: 'D'
STATUS_S = 1.0


def sik_units(dbm: float) -> int:
    """A level in dBm as a SiK radio reports it: (dBm + 127) * 1.9, 0..254."""
    return int(min(max(round((dbm + 127.0) * 1.9), 0), 254))


class _Sink:
    def __init__(self) -> None:
        self.data = bytearray()

    def write(self, buf: bytes) -> None:
        self.data += buf


class WaterLink:
    """The link model of one twin run (see the module docstring)."""

    def __init__(self, link: link_mod.Link, seed: int) -> None:
        self.link = link
        self.channel = link_mod.Channel(link, np.random.default_rng([seed, 16]))
        self.sik = link.radio.name.startswith("sik")
        self._sink = _Sink()
        self._mav = mavlink.MAVLink(self._sink, srcSystem=SIK_SYSID, srcComponent=SIK_COMPID)
        self.t = 0.0
        self.up = True
        self._last_ok_t = 0.0
        self._last_ok_depth = 0.0
        self._next_status = STATUS_S
        self.events: list = []        # {"event": "lost"|"regained", "t": s, "depth_m": m}
        self.lost_time_s = 0.0
        self._lost_since: Optional[float] = None
        self.frames_lost = [0, 0]     # [vehicle -> ground, ground -> vehicle]
        self.chunks_lost = [0, 0]
        self.fixes_used = 0
        self.ok = True

    def step(self, t: float, depth: float, dt: float) -> None:
        """Frame time ``t`` (s), the antenna at ``depth`` (m)."""
        self.t = t
        self.channel.step(depth, dt)
        self.ok = self.channel.passes()
        if self.ok:
            if not self.up:
                self.up = True
                self.lost_time_s += t - self._lost_since
                self._lost_since = None
                self.events.append({"event": "regained", "t": round(t, 3), "depth_m": round(depth, 3)})
                log.info("t=%.2f s: the radio link is back (antenna %.2f m deep)", t, depth)
            self._last_ok_t = t
            self._last_ok_depth = depth
        elif self.up and t - self._last_ok_t >= LOST_AFTER_S:
            self.up = False
            self._lost_since = self._last_ok_t
            self.events.append({"event": "lost", "t": round(self._last_ok_t, 3),
                                "depth_m": round(self._last_ok_depth, 3)})
            log.info("t=%.2f s: the radio link is lost below %.2f m (nothing crossed for %g s; %s reaches "
                     "%.2f m in this water)", self._last_ok_t, self._last_ok_depth, LOST_AFTER_S,
                     self.link.radio.name, self.link.reach_m)

    def crosses(self, data: bytes, direction: int) -> bool:
        """Whether this frame's bytes one way (0: vehicle -> ground, 1:
        ground -> vehicle) cross; counts what is lost."""
        if self.ok or not data:
            return True
        self.chunks_lost[direction] += 1
        self.frames_lost[direction] += _frames_in(data)
        return False

    def statuses(self) -> tuple[bytes, bytes]:
        """RADIO_STATUS for the ground and for the vehicle, due now (b"" if none)."""
        if not self.sik or self.t < self._next_status:
            return b"", b""
        self._next_status += STATUS_S
        r = self.link.radio
        level = self.channel.level_db + r.sensitivity_dbm
        heard = sik_units(max(level, r.noise_dbm))
        noise = sik_units(r.noise_dbm)
        # the other radio's report crosses the air: while the link is down none does
        rem = heard if self.ok else 0
        out = []
        # rxerrors: what each radio failed to receive (the ground's: the
        # vehicle's sends, direction 0; the vehicle's: the ground's, 1)
        for k in (0, 1):
            self._mav.radio_status_send(heard, rem, 100, noise, noise, self.chunks_lost[k] & 0xFFFF, 0)
            out.append(bytes(self._sink.data))
            self._sink.data.clear()
        return out[0], out[1]

    def report(self, end_t: float) -> dict:
        lost = self.lost_time_s + (end_t - self._lost_since if self._lost_since is not None else 0.0)
        first = next((e for e in self.events if e["event"] == "lost"), None)
        return {
            "radio_model": self.link.radio.name,
            "water_conductivity_s_per_m": self.link.water.conductivity,
            "radio_reach_m": self.link.reach_m,
            "link_lost_depth_m": first["depth_m"] if first else None,
            "link_lost_at_s": first["t"] if first else None,
            "link_events": self.events,
            "time_without_link_s": round(lost, 3),
            "frames_lost_to_ground": self.frames_lost[0],
            "frames_lost_to_vehicle": self.frames_lost[1],
            "fixes_used": self.fixes_used,
        }


def _frames_in(data: bytes) -> int:
    """MAVLink frames begun in ``data`` (a cut last one counts)."""
    from roboray.sim.twin.ground import _frame_length

    n = pos = 0
    while pos < len(data):
        if data[pos] in (0xFD, 0xFE):
            k = _frame_length(data, pos)
            n += 1
            pos += k if k > 0 else 1
        else:
            pos += 1
    return n
