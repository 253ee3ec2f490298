"""Signing on the vehicle, with pymavlink as the attacker: the endpoint with the
firmware's key record (firmware/link.py SigningKeeper on a FlashRecord), across a restart."""

from __future__ import annotations

from pymavlink.dialects.v20 import common as pm

from roboray.firmware.flash_record import FlashRecord
from roboray.firmware.link import BOOT_MARGIN_S, SigningKeeper
from roboray.shared import modes as M
from roboray.shared import param_defs
from roboray.shared.mavlink.endpoint import Endpoint
from roboray.shared.mavlink.signing import Signing, key_from_passphrase
from roboray.shared.mavlink.telemetry import Telemetry
from roboray.shared.params import ParamTable

from test_mavlink_endpoint import Ground, acks, exchange

KEY = key_from_passphrase("sesame")
T0 = 200_000_000_000_000          # the saved clock (10 us units since 2015: ~63 years)


class Board:
    """The endpoint, its Signing and the key record, as firmware/link.py wires them."""

    def __init__(self, ground, path):
        self.params = ParamTable(param_defs.PARAMS)
        self.modes = M.Modes(None)
        self.signing = Signing()
        self.keeper = SigningKeeper(self.signing, FlashRecord(str(path)))
        self.keeper.load()
        self.ep = Endpoint(ground.pipe, self.params, self.modes, Telemetry(), self.signing)
        self.ep.on_setup_signing = self.keeper.save
        self.now = 0

    def step(self, ms=10, n=1):
        for _ in range(n):
            self.now += ms
            self.ep.update(self.now)
            self.keeper.service(self.now, self.modes.armed)


def signed_ground(ts, key=KEY, link=1):
    g = Ground(key=key)
    for m in (g.mav, g.rx):
        m.signing.timestamp = ts
        m.signing.link_id = link
    return g


def arm(g, value=1):
    g.mav.command_long_send(1, 1, pm.MAV_CMD_COMPONENT_ARM_DISARM, 0, value, 0, 0, 0, 0, 0, 0)


def record_frame(g, send):
    """The bytes ``send(g)`` puts on the air (what an attacker records)."""
    send(g)
    return bytes(g.pipe.to_vehicle)


def texts(msgs):
    return [m.text for m in msgs if m.get_type() == "STATUSTEXT"]


def test_setup_signing_then_the_attacks_then_the_legitimate_ground(tmp_path):
    path = tmp_path / "signing.bin"
    g = Ground()
    v = Board(g, path)
    assert v.signing.key is None
    # SETUP_SIGNING on a vehicle without a key: taken unsigned (as every command then)
    g.mav.setup_signing_send(1, 1, list(KEY), T0)
    msgs = exchange(g, v)
    assert "signing key set" in texts(msgs) and v.signing.key == KEY and v.signing.timestamp() >= T0
    assert FlashRecord(str(path)).load()[:32] == KEY           # kept on flash at once

    # unsigned: refused and counted, told by STATUSTEXT; RADIO_STATUS still taken
    arm(g)
    g.mav.radio_status_send(80, 70, 50, 30, 20, 3, 0)
    msgs = exchange(g, v)
    assert not v.modes.armed and v.ep.unsigned == 1 and v.ep.radio_count == 1
    assert any("unsigned msg 76" in t for t in texts(msgs))

    # wrong key: refused
    bad = signed_ground(T0 + 1000, key=key_from_passphrase("guess"))
    v.ep.transport = bad.pipe
    arm(bad)
    exchange(bad, v)
    assert not v.modes.armed and v.signing.bad == 1

    # the legitimate ground arms; its frame recorded by the attacker
    good = signed_ground(v.signing.timestamp() + 100)
    v.ep.transport = good.pipe
    recorded = record_frame(good, arm)
    msgs = exchange(good, v)
    assert v.modes.armed and acks(msgs)[0].result == 0
    good.mav.command_long_send(1, 1, pm.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0)
    exchange(good, v)
    assert not v.modes.armed                               # disarmed: the clock is saved
    # replay: refused
    good.pipe.to_vehicle += recorded
    exchange(good, v)
    assert not v.modes.armed and v.signing.replays == 1

    # a far-future frame (a year ahead): refused, counted, not adopted
    clock = v.signing.timestamp()
    future = signed_ground(clock + 365 * 86400 * 100000, link=7)
    v.ep.transport = future.pipe
    arm(future)
    exchange(future, v)
    assert not v.modes.armed and v.signing.future == 1 and v.signing.timestamp() < clock + 60 * 100000

    # the legitimate ground still works
    v.ep.transport = good.pipe
    arm(good)
    msgs = exchange(good, v)
    assert v.modes.armed and acks(msgs)[-1].result == 0
    arm(good, 0)
    exchange(good, v)

    # restart: key and clock from flash, the clock past everything accepted before
    last = v.signing.timestamp()
    g2 = Ground()
    v2 = Board(g2, path)
    assert v2.signing.key == KEY and v2.signing.timestamp() >= last
    assert v2.signing.timestamp() >= v.keeper.saved_hi * 2 ** 24 + v.keeper.saved_lo + BOOT_MARGIN_S * 100000
    v2.ep.transport = good.pipe
    good.pipe.to_vehicle += recorded               # the recorded arm, after the restart: refused
    exchange(good, v2)
    assert not v2.modes.armed and v2.signing.replays == 1
    # a ground that heard the vehicle (pymavlink follows its clock) gets through
    g3 = signed_ground(0, link=2)
    v2.ep.transport = g3.pipe
    g3.mav.heartbeat_send(6, 8, 0, 0, 0)
    exchange(g3, v2)                              # refused (behind the clock), but g3 hears the vehicle
    g3.mav.signing.timestamp = max(g3.mav.signing.timestamp, g3.rx.signing.timestamp)
    arm(g3)
    msgs = exchange(g3, v2)
    assert v2.modes.armed and acks(msgs)[-1].result == 0
    arm(g3, 0)
    exchange(g3, v2)

    # signing remove: an all-zero key, signed with the current one
    g3.mav.setup_signing_send(1, 1, [0] * 32, 0)
    exchange(g3, v2)       # (the answer goes unsigned: g3, still keyed, refuses it)
    assert v2.signing.key is None
    assert FlashRecord(str(path)).load()[:32] == bytes(32)


def test_the_unsigned_whitelist_is_radio_status_and_radio():
    from roboray.shared.mavlink.endpoint import UNSIGNED_OK
    assert UNSIGNED_OK == (pm.MAVLINK_MSG_ID_RADIO_STATUS, 166)   # 166: RADIO (ardupilotmega.xml)


def test_setup_signing_is_refused_while_armed(tmp_path):
    g = Ground()
    v = Board(g, tmp_path / "signing.bin")
    assert v.modes.arm(True)[0]
    g.mav.setup_signing_send(1, 1, list(KEY), T0)
    msgs = exchange(g, v)
    assert v.signing.key is None and any("disarm first" in t for t in texts(msgs))
