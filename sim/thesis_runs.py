"""The thesis's sec. 5.2 simulations of its backstepping controller
(``roboray-sim thesis-control``): the wings at 45 deg, a fall at 0.3 m/s,
with and without its control, fed the true state. Why they move the
vehicle so little: ``sim/analysis/authority.py``."""

from __future__ import annotations

import math
from typing import Optional

import numpy as np

from roboray.shared import modes as M
from roboray.sim.dynamics import Model
from roboray.sim.flight import (CONTROL_EVERY, TICK_HZ, FlightSpec, TruthEstimate, _single_thread, make_controller,
                                vehicle_params)


def thesis_run(spin: float = 0.5, kv2: Optional[float] = None, control: bool = True, duration: float = 60.0,
               dt: float = 0.005) -> dict:
    """Sec. 5.2's simulations: wings at 45 deg, falling at v3 = 0.3 m/s with
    a spin ``spin`` (rad/s) about z_c, no perturbation; with ``control``
    the backstepping controller tracks +y_c at 0.3 m/s (its descent kept at
    0.3 m/s), fed the true state, for ``duration`` s. ``kv2``: the K weight
    on the y_c velocity (sec. 5.2.2's re-weighting; None: K = I)."""
    from array import array

    from roboray.sim.simulate import simulate

    _single_thread()
    params = vehicle_params(FlightSpec())
    model = Model(params)
    wings = np.full(4, math.radians(45.0))
    x0 = model.state(velocity=(0.0, 0.0, 0.3), rates=(0.0, 0.0, spin), wings=wings)
    ctl = None
    if control:
        overrides = (("CTL_BS_KV2", kv2),) if kv2 is not None else ()
        ctl, _ = make_controller(FlightSpec(controller="backstepping", ctl=overrides))
        # +y_c of the start (east at heading 0) at 0.3 m/s, down at 0.3 m/s
        ctl.set_reference(0.0, 0.0, 0.0, 0.0, 0.3, 0.3, 0.0)
    est = TruthEstimate()
    out = array("f", np.degrees(0) + wings)
    ctl_dt = CONTROL_EVERY / TICK_HZ
    state = {"tick": 0, "u": []}

    def controller(t, x):
        if ctl is None:
            return wings[None, :]
        sd = model.servo_rate(x[:, 13:17], np.array(out, float)[None, :])
        est.update(x[0], model.velocities(x, sd)[0])
        ctl.step(state["tick"] * int(ctl_dt * 1e6), M.VELOCITY, est, out)
        state["tick"] += 1
        state["u"].append(np.array(ctl.u, float))
        return np.array(out, float)[None, :]

    run = simulate(model, x0, duration, dt=dt, controller=controller, control_period=ctl_dt)
    v = run.velocity_ned()[:, 0]
    u = np.array(state["u"]) if state["u"] else np.zeros((0, 4))
    return {"t": run.t, "position": run.x[:, 0, 0:3], "velocity": v, "wings": run.x[:, 0, 13:17],
            "command": run.command[:, 0], "u": u, "spin": spin, "kv2": kv2, "control": control}
