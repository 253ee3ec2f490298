"""A reset mid-dive in the twin (issue 26 item 5): on RoboRay's builds the
flight log's ring is in RAM the build keeps across a watchdog reset
(``logram``), so ``--fault watchdog@20`` in target-landing leaves the
dive's records before the reset in log 1, followed by the resumed dive's;
a power cut loses them (log 1: its header and parameters only). Stock
builds keep the heap ring: ``test_flightlog_twin.py``. On the emulated
RP2350 the region is the image's reserved RAM (DTCM, not zeroed at
start); a watchdog reset there is a new life in the same QEMU process,
which no system reset interrupts, so the RAM stays as on the chip."""

from __future__ import annotations

from collections import Counter

import pytest
from pymavlink import DFReader

from roboray.sim.twin import faults
from roboray.sim.twin.runner import Options, run
from roboray.tools.micropython import roboray_host, rp2350_emu


def messages(path):
    log = DFReader.DFReader_binary(str(path))
    out = []
    while (m := log.recv_match()) is not None:
        out.append(m)
    return out


def dive(tmp_path, fault, **kw):
    r = run(Options(scenario="target-landing", faults=[faults.parse(fault)], board_fs=str(tmp_path), **kw))
    logs = sorted(p.name for p in (tmp_path / "logs").glob("*.BIN"))
    return r, logs, messages(tmp_path / "logs" / "00000001.BIN")


def check_kept(r, logs, msgs):
    assert r["resets"] == 1 and r["landing_error_m"] < 0.5
    assert logs == ["00000001.BIN"]           # the resumed dive goes on in the same log
    att = [m.TimeUS / 1e6 for m in msgs if m.get_type() == "ATT"]
    texts = [m.Message for m in msgs if m.get_type() == "MSG"]
    assert "watchdog reset: log continues" in texts
    # armed at ~9 s, the loop hung at 20 s: the records in between are kept
    assert 9.0 < att[0] < 10.0 and sum(1 for t in att if t < 20.0) > 0.6 * 25 * 10
    # and the resumed dive's follow them, to its rest on the bottom
    assert att == sorted(att) and att[-1] > 30.0
    events = [m.Id for m in msgs if m.get_type() == "EV"]
    assert events[:2] == [10, 10]      # armed, and armed again after the reset (the run may end
    #                                    before the flush reaches the at-rest event)


@pytest.mark.skipif(not roboray_host.available(), reason="RoboRay MicroPython's host build runs on Linux on x86")
def test_a_watchdog_reset_mid_dive_keeps_the_dives_log_on_roboray_unix(tmp_path):
    check_kept(*dive(tmp_path, "watchdog@20"))


@pytest.mark.skipif(not roboray_host.available(), reason="RoboRay MicroPython's host build runs on Linux on x86")
def test_a_power_cut_mid_dive_loses_the_dive_since_arming_on_roboray_unix(tmp_path):
    r, logs, msgs = dive(tmp_path, "powercut@20")
    assert r["power_cuts"] == 1
    kinds = Counter(m.get_type() for m in msgs)
    # log 1: the header and parameters made on deck, nothing of the dive
    assert kinds["PARM"] > 50 and kinds["ATT"] == 0
    assert logs == ["00000001.BIN", "00000002.BIN"]     # the resumed dive's own log


@pytest.mark.slow
@pytest.mark.skipif(not rp2350_emu.available(), reason="needs qemu-system-arm")
def test_a_watchdog_reset_mid_dive_keeps_the_dives_log_on_the_emulated_rp2350(tmp_path):
    check_kept(*dive(tmp_path, "watchdog@20", interpreter="rp2350-emu"))
