"""``--port auto``: find the board among the serial ports by its USB vendor id.

MicroPython on a Pico 2 enumerates as a USB CDC serial port with the
Raspberry Pi vendor id (2E8A; product 0005 for MicroPython's own firmware).
The choice is made from pyserial's port listing, so the rules can be checked
on any list of :class:`serial.tools.list_ports_common.ListPortInfo`.
"""

from __future__ import annotations

import logging
from typing import Iterable, Optional

from .errors import NoBoardFound

log = logging.getLogger("roboray.flash")

#: USB vendor id of Raspberry Pi (RP2040/RP2350 boards running MicroPython).
RASPBERRY_PI_VID = 0x2E8A


def describe(port) -> str:
    """One line naming a port: device, product, USB ids, serial number."""
    ids = "[%04x:%04x]" % (port.vid or 0, port.pid or 0)
    parts = [port.device, port.product or port.description or "", ids]
    if port.serial_number:
        parts.append("serial " + port.serial_number)
    return " ".join(p for p in parts if p and p != "n/a")


def candidates(ports: Iterable) -> list:
    """The ports that may be a Pico 2 running MicroPython, sorted by device."""
    return sorted((p for p in ports if p.vid == RASPBERRY_PI_VID), key=lambda p: p.device)


def pick(port: str, ports: Optional[Iterable] = None) -> str:
    """The device to open for ``--port``: itself, or the one board ``auto`` finds.

    ``ports`` defaults to pyserial's listing of this machine's ports.
    """
    if port != "auto":
        return port
    return only_one(
        candidates(listing(ports)), "board", "--port", NoBoardFound,
        "no board found: no serial port has the Raspberry Pi USB vendor id %04x "
        "(connect the Pico 2 with a data cable, check it runs MicroPython, or pass --port)" % RASPBERRY_PI_VID,
        log)


def listing(ports: Optional[Iterable] = None) -> Iterable:
    """``ports``, or pyserial's listing of this machine's serial ports."""
    if ports is None:
        from serial.tools.list_ports import comports

        ports = comports()
    return ports


def only_one(found: list, what: str, option: str, error: type, none: str, logger: logging.Logger) -> str:
    """The device of the one port in ``found``; ``error(none)`` when there is
    none, ``error`` listing them when there are several ``what``s (choose
    with ``option``)."""
    if not found:
        raise error(none)
    if len(found) > 1:
        raise error("%d %ss found, choose one with %s: %s"
                    % (len(found), what, option, "; ".join(describe(p) for p in found)))
    logger.info("using %s", describe(found[0]))
    return found[0].device
