"""The command line shared by the generators of committed board tables
(``gen_allocation.py``, ``gen_plant.py``): write the module, or with
``--check`` say whether the committed one is what the generator makes."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Callable, Optional, Sequence

REFERENCE = "sim/vehicles/reference.py"


def generator_main(prog: str, description: str, generate: Callable[[object, str], str], default_out: Path,
                   argv: Optional[Sequence[str]] = None) -> int:
    """``generate(params, source_name) -> module text`` for the reference
    vehicle or ``--vehicle FILE``; exit 0 written or up to date, 1 out of date."""
    parser = argparse.ArgumentParser(prog=prog, description=description)
    parser.add_argument("--out", type=Path, default=default_out)
    parser.add_argument("--vehicle", type=Path, default=None, help="a copy of " + REFERENCE)
    parser.add_argument("--check", action="store_true", help="exit 1 if the committed file differs")
    args = parser.parse_args(argv)
    params = None
    source = REFERENCE
    if args.vehicle is not None:
        from roboray.sim.vehicle import load_params

        params = load_params(args.vehicle)
        source = args.vehicle.name
    text = generate(params, source)
    if args.check:
        same = args.out.exists() and args.out.read_text() == text
        print("%s is %s" % (args.out, "up to date" if same else "out of date"))
        return 0 if same else 1
    args.out.write_text(text)
    print("wrote %s" % args.out)
    return 0
