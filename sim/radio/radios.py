"""The radios ``--radio-model`` names, from their datasheets.

- ``sik-433``, ``sik-915``: the SiK telemetry radio (3DR / HolyBro, Si1000
  with SiK firmware): 100 mW (20 dBm) out, receive sensitivity -117 dBm
  (HolyBro's SiK Telemetry Radio V3 page: "Receive sensitivity -117 dBm";
  SiK's own documentation gives "to -121 dBm" at its lowest air rates), at
  SiK's default air rate of 64 kbps. Antennas: the stock 1/2-wave dipoles,
  2 dBi assumed on both ends.
- ``hc12-433``: the HC-12 (Si4463) of the buildable vehicle's parts table.
  HC-12 user manual v2.4 (HC Tech, sold by Seeed): 100 mW (20 dBm); in its
  default FU3 mode the air rate follows the UART's baud rate (1200-2400:
  5,000 bps; 4800-9600: 15,000; 19,200-38,400: 58,000; 57,600-115,200:
  236,000) and the sensitivity follows the air rate (-116, -111, -106,
  -100 dBm; -124 dBm in FU4 at 500 bps). The vehicle's UART runs at
  57,600 baud (``sim/vehicles/buildable.py``), so its air rate is 236 kbps
  and its sensitivity -100 dBm: 17 dB less than the manual's headline
  -117 dBm (the v2.3 manual's figure at 5,000 bps). Antenna: the module's
  spring antenna, 0 dBi assumed on both ends.

The receiver's noise floor (for RADIO_STATUS ``noise``) is kTB + NF:
-174 dBm/Hz + 10 log10(air rate) + 6 dB (an assumed noise figure; the
bandwidth of a 2-FSK channel taken as its bit rate).
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Radio:
    name: str
    part: str
    freq_hz: float
    tx_dbm: float
    sensitivity_dbm: float
    air_rate_bps: float
    antenna_dbi: float        #: each end's antenna gain (the ground's and the vehicle's alike)
    source: str

    @property
    def noise_dbm(self) -> float:
        """The receiver's noise floor, kTB + NF (module docstring)."""
        return -174.0 + 10.0 * math.log10(self.air_rate_bps) + 6.0


#: HC-12 FU3: (highest UART baud, air rate bps, sensitivity dBm), manual v2.4.
HC12_FU3 = ((2400, 5000.0, -116.0), (9600, 15000.0, -111.0), (38400, 58000.0, -106.0),
            (115200, 236000.0, -100.0))
#: The buildable vehicle's radio UART (``sim/vehicles/buildable.py``'s radio part).
VEHICLE_BAUD = 57600


def hc12(baud: int = VEHICLE_BAUD) -> Radio:
    """The HC-12 in FU3 at a UART baud rate: its air rate and sensitivity follow."""
    for top, air, sens in HC12_FU3:
        if baud <= top:
            return Radio("hc12-433", "HC-12 433 MHz (Si4463)", 433.4e6, 20.0, sens, air, 0.0,
                         "HC-12 user manual v2.4: 20 dBm; FU3 at %d baud: %g bps air, %g dBm" % (baud, air, sens))
    raise ValueError("HC-12 UART baud %r: at most 115200" % (baud,))


RADIOS = {
    "sik-433": Radio("sik-433", "SiK telemetry radio 433 MHz", 433.0e6, 20.0, -117.0, 64000.0, 2.0,
                     "HolyBro SiK V3: 20 dBm, -117 dBm; SiK default air rate 64 kbps"),
    "sik-915": Radio("sik-915", "SiK telemetry radio 915 MHz", 915.0e6, 20.0, -117.0, 64000.0, 2.0,
                     "HolyBro SiK V3: 20 dBm, -117 dBm; SiK default air rate 64 kbps"),
    "hc12-433": hc12(),
}
NAMES = tuple(RADIOS)


def vehicle_radio() -> str:
    """The buildable vehicle's radio, by its parts table's radio part."""
    from roboray.sim.vehicles.buildable import PARTS

    part = next(p[1] for p in PARTS if p[0] == "radio")
    if "HC-12" in part:
        return "hc12-433"
    if "SiK" in part:
        return "sik-915" if "915" in part else "sik-433"
    raise ValueError("the buildable vehicle's radio %r is none of %s" % (part, ", ".join(NAMES)))


def radio(name: str | None) -> Radio:
    """``RADIOS[name]``; None: the buildable vehicle's."""
    if name is None:
        name = vehicle_radio()
    if name not in RADIOS:
        raise ValueError("radio %r: one of %s" % (name, ", ".join(NAMES)))
    return RADIOS[name]
