"""``roboray-ground log plot``: what a person reads off a dive's plot
(issue 26 items 5 and 8): gaps drawn as gaps, a heading through north as a
broken line, legends beside the data, a named failsafe, a top view that
does not magnify centimetres of noise."""

from __future__ import annotations

import math
import struct

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from roboray.firmware.flightlog import dataflash as df  # noqa: E402
from roboray.firmware.flightlog import logger as L  # noqa: E402
from roboray.ground import binplot, plot as tlog_plot  # noqa: E402
from roboray.ground.series import broken, gaps  # noqa: E402


def test_broken_series_split_at_gaps_and_at_the_heading_wrap():
    t = [0.0, 0.04, 0.08, 0.12, 5.0, 5.04]
    y = [350.0, 355.0, 2.0, 8.0, 10.0, 11.0]
    bt, by = broken(t, y, wrap=360.0)
    # NaN between 355 and 2 (the wrap) and between 0.12 s and 5 s (the gap)
    assert np.isnan(by).sum() == 2
    assert list(np.nonzero(np.isnan(by))[0]) == [2, 5]
    assert gaps(t) == [(0.12, 5.0)]
    # a slow record's own period is no gap
    assert gaps([0.0, 1.0, 2.0, 3.0]) == []


def _bin(gap=(20.0, 27.0), end=32.0):
    """A dive's log as the firmware writes it: ATT at 25 Hz turning through
    north, EST within a few cm of the release point, a failsafe raised, and
    nothing recorded during ``gap`` (a full ring)."""
    w = df.Writer(400_000)
    clock = df.Clock()
    w.stamp(clock)
    assert w.header(L.RECORDS)

    def put(rec, *values):
        values = values + (0,) * (len(rec.fmt) - 1 - len(values))   # fields after these: zero
        o = w.reserve(rec.length)
        assert o >= 0
        struct.pack_into(rec.pack, w.buf, o, df.HEAD1, df.HEAD2, rec.type_id, w.t0, w.t1, w.t2, w.t3, *values)

    clock.set_us(9_000_000)
    w.stamp(clock)
    put(L.MODE, b"PASSIVE", 19, 0)   # (HEARTBEAT's custom_mode of PASSIVE)
    put(L.EV, L.EV_ARMED)
    k = 0
    while clock.us() < end * 1e6:
        clock.advance(40_000)
        k += 1
        s = clock.us() / 1e6
        if gap[0] < s < gap[1]:
            continue
        w.stamp(clock)
        yaw = (350.0 + 2.0 * (s - 9.0)) % 360.0
        put(L.ATT, 10, -20, int(yaw * 100))
        if k % 4 == 0:
            put(L.EST, 0.03 * math.sin(s), 0.04 * math.cos(3 * s), min(10.0, 0.3 * (s - 9)), 0.0, 0.0, 0.3, 0.0, 0.0)
        if k == 150:
            put(L.ERR, L.ERR_FAILSAFE_BASE + 2, 1)   # battery low raised
    out = bytearray()
    while w.pending():
        o, n = w.chunk(4096)
        out += w.buf[o:o + n]
        w.taken(n)
    return bytes(out)


def _inside(fig, artist, ax):
    r = fig.canvas.get_renderer()
    a = artist.get_window_extent(r)
    b = ax.get_window_extent(r)
    return a.x0 < b.x1 - 1 and a.x1 > b.x0 + 1 and a.y0 < b.y1 - 1 and a.y1 > b.y0 + 1


def test_the_dive_plot_reads_as_the_dive_went():
    fig, counts = binplot.figure(_bin())
    try:
        top, depth, att, yaw, wings, timeline = fig.axes
        # the top view spans at least 2 m: centimetres of noise are not magnified
        assert top.get_xlim()[1] - top.get_xlim()[0] >= 2.0 - 1e-9
        assert top.get_ylim()[1] - top.get_ylim()[0] >= 2.0 - 1e-9
        # the heading is a line, broken where it wraps and where the ring dropped records
        (line,) = yaw.get_lines()
        assert line.get_linestyle() == "-"
        ys = np.asarray(line.get_ydata(), float)
        finite = ys[~np.isnan(ys)]
        assert finite.min() < 20 and finite.max() > 340
        runs = np.split(ys, np.nonzero(np.isnan(ys))[0])
        for run in runs:
            run = run[~np.isnan(run)]
            assert np.all(np.abs(np.diff(run)) < 180)      # no stroke across the axis
        xs = np.asarray(line.get_xdata(), float)
        assert not np.any((xs > 20.05) & (xs < 26.95))      # nothing drawn across the gap
        assert np.isnan(ys).sum() >= 2
        # the gap is shaded where it is
        shaded = [p for p in depth.patches if p.get_label() == "not recorded"]
        assert shaded and abs(shaded[0].get_x() - 20.0) < 0.1
        # legends beside the panels, never over their data
        fig.canvas.draw()
        for ax in (depth, att, wings):
            legend = ax.get_legend()
            assert legend is not None and not _inside(fig, legend, ax)
        # the failsafe's marker says which
        assert "battery low" in [t.get_text().strip() for t in timeline.texts]
    finally:
        plt.close(fig)


def test_the_telemetry_plot_breaks_at_a_radio_gap_and_the_heading_wrap():
    # ATTITUDE at 10 Hz through +-180 deg, the link faded from 20 to 27 s
    from pymavlink.dialects.v20 import common

    mav = common.MAVLink(None, srcSystem=1, srcComponent=1)
    data = bytearray()
    for k in range(100, 320):
        t = k / 10.0
        if 20.0 < t < 27.0:
            continue
        yaw = math.radians(((170.0 + 2.0 * (t - 10.0) + 180.0) % 360.0) - 180.0)
        frame = common.MAVLink_attitude_message(int(t * 1000), 0.0, 0.0, yaw, 0.0, 0.0, 0.0).pack(mav)
        data += struct.pack(">Q", int((1_780_000_000 + t) * 1e6)) + frame
    fig, counts = tlog_plot.figure(bytes(data))
    try:
        att = fig.axes[1]
        (yaw,) = [ln for ln in att.get_lines() if ln.get_label() == "yaw"]
        ys = np.asarray(yaw.get_ydata(), float)
        xs = np.asarray(yaw.get_xdata(), float)
        assert np.isnan(ys).sum() == 2             # the wrap at 180 deg and the fade
        for run in np.split(ys, np.nonzero(np.isnan(ys))[0]):
            run = run[~np.isnan(run)]
            assert np.all(np.abs(np.diff(run)) < 180)
        assert not np.any((xs > 10.05) & (xs < 16.95))   # s from the first record: the fade is 10-17 s
        fig.canvas.draw()
        assert not _inside(fig, att.get_legend(), att)
    finally:
        plt.close(fig)
