"""Campaigns: many independent runs (Monte Carlo landings, the grid points
of a map, the design points of a sweep) on this machine's processes or on
a Dask cluster, their rows in a file that survives a crash.

The API a command builds on::

    from roboray.sim.campaign import Campaign, run, add_engine_options, engine_from_args

    campaign = Campaign(
        kind="sweep",                       # names the campaign in its results file
        params={"vehicle": "...", "seed": 0},  # JSON-able: a resume must match them
        tasks=[...],                        # picklable; task i depends on i alone
        fn=my_module.row_of,                # module-level, pure: task -> row dict
        columns=[("cd", "float"), ("landed", "bool"), ...])  # int, float, bool, str
    engine = engine_from_args(args)         # --workers N | --cluster tcp://H:P | local:N
    outcome = run(campaign, engine, results="runs.csv", done=lambda i: bar.update(1),
                  notice=stderr_notice(), started=lambda total, present: ...)
    outcome.rows     # one row per task, in index order
    outcome.stats    # tasks, present (from the file), ran, engine, workers, wall_s,
                     # task_cpu_s and task_wall_s (the tasks' own), restarts (pools rebuilt)

- Determinism: a task's row depends on the task alone. Every worker is
  single-threaded (numba, OpenMP, BLAS), so the rows are bit for bit the
  same on any engine with any number of workers; they come back in index
  order whatever order they finished in.
- Results (``results.py``): ``.csv`` or ``.parquet`` (pyarrow), one row a
  task with its index in column ``run``, appended and flushed as each
  ends; run again, the same command continues: rows present are not run
  again, a line torn by a crash is dropped with a notice and redone. The
  file's first line names the campaign (kind, params, columns) and a
  resume refuses a file of another campaign. ``summary_path(results)`` is
  where a command puts its summary JSON.
- Engines (``engines.py``): this process (one worker), a pool of spawned
  processes (a worker that dies breaks the pool; the unfinished tasks go
  to a new one), or Dask distributed (``tcp://`` of a running scheduler,
  or ``local:N``; Dask re-runs a task whose worker was lost). A row that
  arrives twice is kept once.
- Without ``results``, rows may be any picklable value (the maps' trims).

``grid.py`` runs the maps' and the envelope's settling drops as tasks;
``bench.py`` measures the engines (``roboray-sim bench campaign``).
"""

from roboray.sim.campaign.engines import (DaskCluster, Engine, EngineError, InProcess, ProcessPool, make_engine,
                                          parse_cluster, stderr_notice)
from roboray.sim.campaign.options import add_engine_options, cli_errors, engine_from_args
from roboray.sim.campaign.results import ResultsError, ResultsFile, read_rows, summary_path
from roboray.sim.campaign.runner import Campaign, Outcome, run

__all__ = ["Campaign", "Outcome", "run", "Engine", "EngineError", "InProcess", "ProcessPool", "DaskCluster",
           "make_engine", "parse_cluster", "stderr_notice", "add_engine_options", "cli_errors", "engine_from_args",
           "ResultsError", "ResultsFile", "read_rows", "summary_path"]
