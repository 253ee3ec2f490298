"""Run a campaign on an engine, keeping every row once, on disk as it comes.

The runner owns the bookkeeping the engines do not: which indices are
already in the results file (not run again), each new row written the
moment it arrives, a row that comes twice (a task re-run after its worker
died, having finished after all) kept once, progress as each task ends,
and the rows handed back in index order whatever order they ended in.
"""

from __future__ import annotations

import time
from typing import Callable, Optional, Sequence

from roboray.sim.campaign.engines import Engine
from roboray.sim.campaign.results import ResultsFile, check_row, header


class Campaign:
    """Independent tasks and the pure function that turns one into a row.

    ``tasks``: picklable, each a function of its index alone (its seed
    drawn from the index, never from where or when it runs). ``fn``: a
    module-level function (engines pickle it by name), task -> row. With a
    results file, a row is a dict of ``columns`` (``(name, type)`` pairs,
    types ``int``, ``float``, ``bool``, ``str``; None allowed) and the
    campaign's ``kind`` and ``params`` (JSON-able) name it in the file.
    """

    def __init__(self, kind: str, params: dict, tasks: Sequence, fn: Callable,
                 columns: Optional[Sequence[tuple[str, str]]] = None) -> None:
        if not tasks:
            raise ValueError("a campaign needs at least one task")
        self.kind = kind
        self.params = dict(params)
        self.tasks = list(tasks)
        self.fn = fn
        self.columns = list(columns) if columns is not None else None

    def __len__(self) -> int:
        return len(self.tasks)


class Outcome:
    """What a campaign ran: ``rows`` in index order and ``stats``."""

    def __init__(self, rows: list, stats: dict) -> None:
        self.rows = rows
        self.stats = stats


def run(campaign: Campaign, engine: Engine, results: Optional[str] = None,
        done: Callable[[int], None] = lambda index: None,
        notice: Callable[[str], None] = lambda line: None, started: Callable[[int, int], None] = lambda n, k: None
        ) -> Outcome:
    """Every task of ``campaign`` on ``engine`` (started and closed here
    unless already started by the caller: a bench reuses one).

    ``results``: a ``.csv`` or ``.parquet`` file; the rows already in it
    are taken, not run. ``started(total, present)`` is called once the file
    is read, ``done(index)`` as each task ends, ``notice(line)`` with what
    the user should hear (a torn line dropped, a worker lost)."""
    total = len(campaign)
    rows: dict = {}
    store = None
    if results is not None:
        if campaign.columns is None:
            raise ValueError("a results file needs the campaign's columns")
        store = ResultsFile(results, header(campaign.kind, campaign.params, campaign.columns), notice=notice)
        rows = store.open(total)
    started(total, len(rows))
    todo = [(i, campaign.tasks[i]) for i in range(total) if i not in rows]
    stats = {"tasks": total, "present": len(rows), "ran": 0, "engine": engine.describe(), "task_cpu_s": 0.0,
             "task_wall_s": 0.0, "wall_s": 0.0, "restarts": 0}
    t0 = time.perf_counter()
    try:
        if todo:
            with engine.session():
                stats["engine"] = engine.describe()
                stats["workers"] = engine.workers
                for index, row, cpu_s, wall_s in engine.map_unordered(campaign.fn, todo):
                    if index in rows:
                        continue
                    if store is not None:
                        check_row(row, store.columns)
                        store.append(index, row)
                    rows[index] = row
                    stats["ran"] += 1
                    stats["task_cpu_s"] += cpu_s
                    stats["task_wall_s"] += wall_s
                    done(index)
                stats["restarts"] = getattr(engine, "restarts", 0)
        if store is not None:
            store.finish(rows)
    except KeyboardInterrupt:
        if store is not None:
            store.close()
            notice("interrupted with %d of %d rows in %s: the same command continues from there"
                   % (len(rows), total, results))
        raise
    finally:
        if store is not None:
            store.close()
    stats["wall_s"] = time.perf_counter() - t0
    missing = [i for i in range(total) if i not in rows]
    if missing:   # an engine that ends without every task is a bug, not bad luck
        raise RuntimeError("the engine ended with %d tasks unrun (first %d)" % (len(missing), missing[0]))
    return Outcome([rows[i] for i in range(total)], stats)

