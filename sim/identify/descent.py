"""The firmware's descent model fitted to the identified vehicle.

The descent model (``shared/estimator/descent_model.py``) is what the
estimator dead-reckons with where no fix arrives; its table was fitted to
the reference vehicle in the simulator. For a vehicle identified from its
own dive the same fit is made on that vehicle: the estimator's standard
flights (``estimation.dynamics_descent``: wings moved every 6-12 s to the
configurations a controller flies, from rest at the surface) flown by the
fitted vehicle, and ``estimation.calibrate_descent_model`` on them, the
method and the flights that made today's defaults. The log itself holds
a few configurations only (a controller's glide); the standard flights
span the folds and the differential the firmware will command.
"""

from __future__ import annotations

from typing import Callable, Optional

from roboray.shared.estimator.descent_model import PARAM_NAMES
from roboray.sim import estimation as E
from roboray.sim.vehicle import VehicleParams

#: Seeds of the standard flight the table is fitted on.
SEEDS = tuple(range(6))


def fit(params: VehicleParams, seeds=SEEDS, done: Optional[Callable[[], None]] = None) -> dict:
    """The DR_* parameters for the vehicle ``params``, and the fit's residual."""
    truths = []
    for s in seeds:
        truths.append(E.dynamics_descent(s, params=params))
        if done:
            done()
    table = E.calibrate_descent_model(truths)
    values = dict(zip(PARAM_NAMES, list(table["glide_gain"]) + [table["diff_gain"], table["tau_s"]]))
    return {"params": values, "residual_mps": table["residual_mps"], "seeds": list(seeds)}
