"""``roboray-sim``: the simulator, the analyses and the benchmarks."""

from __future__ import annotations

import importlib
from typing import Optional, Sequence

from roboray.tools.cli import make_parser, run

#: One module a topic; each has ``register(sub, bench)`` adding its commands
#: to the top level and to ``roboray-sim bench``.
TOPICS = (
    "roboray.sim.commands.dynamics",
    "roboray.sim.commands.analysis",
    "roboray.sim.commands.interpreter",
    "roboray.sim.commands.mavlink",
    "roboray.sim.commands.flash",
    "roboray.sim.commands.hardware",
    "roboray.sim.commands.estimator",
    "roboray.sim.commands.control",
    "roboray.sim.commands.campaign",
    "roboray.sim.commands.sweep",
    "roboray.sim.commands.board",
    "roboray.sim.commands.sil",
    "roboray.sim.commands.identify",
    "roboray.sim.commands.radio",
)


def build_parser():
    parser, sub = make_parser("roboray-sim", "RoboRay simulator, analyses and benchmarks.")
    bench_parser = sub.add_parser("bench", help="benchmarks that print figures (JSON with --json)",
                                  description="Benchmarks; each prints its figures, one JSON document with --json.")
    bench = bench_parser.add_subparsers(title="benchmarks", metavar="BENCH", parser_class=type(parser))
    for name in TOPICS:
        importlib.import_module(name).register(sub, bench)
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    return run(build_parser(), argv)


if __name__ == "__main__":
    raise SystemExit(main())
