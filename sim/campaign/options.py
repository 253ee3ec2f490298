"""``--workers`` and ``--cluster``: the same two options, the same meaning,
on every command that runs a campaign."""

from __future__ import annotations

import argparse
import contextlib
import os
from typing import Callable, Iterator

from roboray.tools.cli import output_file

from roboray.sim.campaign.engines import Engine, make_engine, parse_cluster, stderr_notice


def at_least(minimum: int, why: str = "") -> Callable[[str], int]:
    """An argparse type: a whole number >= ``minimum`` (``why`` says what a
    smaller one would not be)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError("%r is not a whole number" % text)
        if value < minimum:
            raise argparse.ArgumentTypeError(why % text if why else "%r must be at least %d" % (text, minimum))
        return value
    return parse


_count = at_least(1)

#: An argparse type for every ``--seed``: numpy's SeedSequence takes no
#: negative number (it raised from deep inside a run).
seed = at_least(0, "%r: a seed is a whole number >= 0")


def results_file(text: str) -> str:
    """An argparse type: a results file a campaign can write, .csv or .parquet."""
    path = output_file(text)
    if os.path.splitext(path)[1].lower() not in (".csv", ".parquet"):
        raise argparse.ArgumentTypeError("%s: a results file ends in .csv or .parquet" % text)
    return path


def _cluster(text: str) -> str:
    try:
        return parse_cluster(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc))


def add_engine_options(parser: argparse.ArgumentParser, what: str = "tasks") -> None:
    parser.add_argument("--workers", type=_count, metavar="N",
                        help="local processes running the %s (default: one per CPU)" % what)
    parser.add_argument("--cluster", type=_cluster, metavar="ADDRESS",
                        help="run the %s on Dask instead: tcp://HOST:PORT of a running 'dask scheduler', or "
                             "local:N to start a LocalCluster of N workers here (its dashboard link is printed)"
                        % what)


def engine_from_args(args: argparse.Namespace, prog: str = "roboray-sim") -> Engine:
    """The engine the options name; a usage error (exit 2) when they
    contradict each other."""
    from roboray.tools.cli import UsageError

    try:
        return make_engine(workers=args.workers, cluster=args.cluster, notice=stderr_notice(prog))
    except ValueError as exc:
        raise UsageError(str(exc))


@contextlib.contextmanager
def cli_errors() -> Iterator[None]:
    """An engine that cannot start or a results file of another campaign:
    one line (``CliError``), not a traceback."""
    from roboray.sim.campaign.engines import EngineError
    from roboray.sim.campaign.results import ResultsError
    from roboray.tools.cli import CliError

    try:
        yield
    except (EngineError, ResultsError) as exc:
        raise CliError(str(exc))
