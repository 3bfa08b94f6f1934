"""The ``fperr`` command. It sits on top of every layer: each subcommand lives in the
module that owns it and is imported only when run."""
from __future__ import annotations

import argparse
import importlib
import sys

#: subcommand -> (module, help). Each module defines add_arguments(parser) and run(args).
COMMANDS = {
    "tables": ("predicates.tables", "derived error bounds of every algorithm (paper's figures)"),
    "verify": ("proofs.verify", "check every tolerance constraint for all eps <= 1e-5"),
    "intersect": ("predicates.cli_intersect", "register intersections of two mesh files"),
    "cut": ("predicates.cli_cut", "split a mesh along a cutting mesh (virtual node algorithm)"),
    "demo": ("predicates.cli_demo", "run the built-in 2D and 3D examples"),
    "audit": ("proofs.audit", "shadow execution: measured error against derived bounds"),
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="fperr", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    available = {}
    for name, (modname, help_) in COMMANDS.items():
        try:
            mod = importlib.import_module(modname)
        except ModuleNotFoundError as e:
            if e.name != modname:
                raise
            continue
        p = sub.add_parser(name, help=help_, description=mod.__doc__,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        mod.add_arguments(p)
        available[name] = mod
    args = parser.parse_args(argv)
    return int(available[args.command].run(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
