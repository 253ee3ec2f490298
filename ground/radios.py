"""``--master auto``: find the telemetry radio among the serial ports by its USB ids.

As ``roboray-flash --port auto`` finds a Pico 2 (``tools/flash/ports.py``),
from pyserial's port listing, so the rules can be checked on any list of
:class:`serial.tools.list_ports_common.ListPortInfo`. The USB ids matched
are those of the SiK telemetry radios' USB-serial bridges (3DR, Holybro,
mRo, RFD900):

- FTDI FT231X, 0403:6015;
- Silicon Labs CP210x, 10c4:ea60.

Other USB-serial adapters, and the Pico 2 itself (2e8a), are not taken:
give such a port with ``--master PATH``.
"""

from __future__ import annotations

import logging
from typing import Iterable, Optional

from roboray.tools.cli import CliError
from roboray.tools.flash.ports import listing, only_one

log = logging.getLogger("roboray.ground")

#: (vendor id, product id, what it is) of the radios ``auto`` takes.
RADIO_USB_IDS = (
    (0x0403, 0x6015, "FTDI FT231X (SiK radio)"),
    (0x10C4, 0xEA60, "Silicon Labs CP210x (SiK radio)"),
)


class NoRadioFound(CliError):
    """``--master auto`` found no radio, or several to choose from."""


def candidates(ports: Iterable) -> list:
    """The ports that may be a telemetry radio, sorted by device."""
    ids = {(vid, pid) for vid, pid, _ in RADIO_USB_IDS}
    return sorted((p for p in ports if (p.vid, p.pid) in ids), key=lambda p: p.device)


def pick(master: str, ports: Optional[Iterable] = None) -> str:
    """The connection string for ``--master``: itself, or the one radio ``auto`` finds.

    ``ports`` defaults to pyserial's listing of this machine's ports.
    """
    if master != "auto":
        return master
    return only_one(
        candidates(listing(ports)), "radio", "--master", NoRadioFound,
        "no radio found: no serial port has a SiK radio's USB ids (%s); plug the radio in, or give its port "
        "with --master (roboray-ground ports lists them)" % ", ".join("%04x:%04x" % (v, p) for v, p, _ in RADIO_USB_IDS),
        log)
