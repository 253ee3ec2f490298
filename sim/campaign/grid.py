"""The maps' and the envelope's grid as campaign tasks.

``envelope.search`` and ``stability_map.compute`` drop every wing
configuration of their grid and polish where each settles
(``envelope.settle_batch``), the bulk of their time. ``settler(engine)``
gives them a drop-in ``settle_batch`` that cuts the configurations into
tasks of ``CHUNK`` (cut at the same places whatever the engine: a
configuration settles bit for bit the same in any batch, each vehicle's
state being its own row of the compiled model) and runs them on the
engine, each task a batch of its own; the trims come back in grid order.
On this process alone the whole grid stays one batch, as before.
"""

from __future__ import annotations

import numpy as np

from roboray.sim.campaign.engines import Engine, InProcess
from roboray.sim.campaign.runner import Campaign, run
from roboray.sim.progress import QUIET

#: Configurations a task settles together: enough to keep the compiled
#: batch worth its call, few enough that two workers share a 28-point grid.
CHUNK = 8


def settle_task(task: tuple) -> list:
    """One task: ``(vehicle params, wings (K, 4) deg, seconds)`` -> the K trims."""
    from roboray.sim.analysis.envelope import settle_batch

    params, wings_deg, duration = task
    return settle_batch(params, wings_deg, duration)


def settler(engine: Engine):
    """``envelope.settle_batch``'s signature, its grid run on ``engine``."""
    from roboray.sim.analysis.envelope import settle_batch, settle_cost

    if isinstance(engine, InProcess):
        return settle_batch

    def settle(model_params, wings_deg, duration: float = 40.0, progress=QUIET) -> list:
        wings = np.asarray(wings_deg, float)
        tasks = [(model_params, wings[k:k + CHUNK], duration) for k in range(0, len(wings), CHUNK)]
        campaign = Campaign("settle", {"configurations": len(wings), "duration_s": duration}, tasks, settle_task)
        out = run(campaign, engine, done=lambda i: progress.update(settle_cost(len(tasks[i][1]), duration)))
        return [trim for chunk in out.rows for trim in chunk]

    return settle
