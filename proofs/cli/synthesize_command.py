"""``fperr synthesize``: the smallest tolerance coefficients the proofs accept
(:mod:`proofs.synthesize`, docs/synthesized-tolerances.md), with a progress bar and a
table file in the format its extension says."""
from __future__ import annotations

import argparse
import sys

from .common import error as _error
from .common import output_as
from .common import user_systems as _user_systems


def _add_synthesize(parser: argparse.ArgumentParser) -> None:
    """fperr synthesize: the smallest tolerance coefficients the proofs accept.

    fperr synthesize --dim 2 -o synth_2d.toml
    fperr synthesize --dim 3 --check proofs/data/synth_3d.toml
    fperr synthesize --predicates mypkg.mypreds -o mypreds.toml

Every coefficient of T−, T, T+ is bisected (to within 1 %) against the decision
procedure of fperr verify, bottom-up along the declared facts (proofs.synthesize);
the table written is accepted by fperr verify --tolerances. Prints, per tolerance,
the paper's and the synthesized coefficients and their ratios. --check FILE: exit 1
when FILE differs from a fresh synthesis (stale). --predicates MODULE synthesizes the
table MODULE declares in FPERR_TOLERANCES (its order, facts and predicates; ratios to
the declared table). Exit status 1 when the declared table does not verify (nothing to
start from), 2 for bad arguments or an unusable declaration.
"""
    parser.add_argument("--dim", type=int, choices=(2, 3), action="append",
                        help="dimension (default: both)")
    parser.add_argument("-o", "--output", metavar="FILE.toml|FILE.json",
                        type=output_as(".toml", ".json", what="the table"),
                        help="write the table for fperr verify --tolerances, in the format "
                             "its extension says (TOML or JSON)")
    parser.add_argument("--check", metavar="FILE.toml|FILE.json", type=_table_file,
                        help="exit 1 when FILE is not what a fresh synthesis writes")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--predicates", metavar="MODULE",
                        help="synthesize the table MODULE declares in FPERR_TOLERANCES")


def _run_synthesize(args: argparse.Namespace) -> int:
    from pathlib import Path

    from proofs.synthesize import ratio_table, synthesize, write
    systems = _user_systems(args, "synthesize") if args.predicates else {}
    if isinstance(systems, int):
        return systems
    results = []
    for dim in sorted(systems or set(args.dim or [2, 3])):
        try:
            with _synthesis_bar(dim, systems.get(dim), args.quiet) as bar:
                r = synthesize(dim, progress=lambda *_: bar.update(),
                               system=systems.get(dim))
        except RuntimeError as e:  # the declared table does not verify
            print(f"fperr synthesize: {e}", file=sys.stderr)
            return 1
        except ValueError as e:    # a declaration whose predicates cannot run
            return _error("synthesize", e)
        print(ratio_table(r))
        print(f"{dim}D: {r.probes} probes, {r.seconds:.1f} s; T+ set by a fact equality: "
              f"{', '.join(r.equalities) or 'none'}; all {len(r.report.outcomes)} "
              "constraints hold")
        results.append(r)
    if args.output:
        write(args.output, results, args.predicates)
        print(f"wrote {args.output}")
    if args.check:
        from proofs.synthesize import is_current
        try:
            old = Path(args.check).read_text(encoding="utf-8")
        except OSError as e:
            return _error("synthesize", e)
        if not is_current(old, results, Path(args.check).suffix):
            how = (f"--predicates {args.predicates}" if args.predicates else
                   f"--dim {','.join(str(r.dim) for r in results)}")
            print(f"{args.check} is stale: regenerate with fperr synthesize "
                  f"{how} -o {args.check}",
                  file=sys.stderr)
            return 1
        print(f"{args.check} is up to date")
    return 0


def _table_file(text: str) -> str:
    """argparse type of synthesize --check: a table file, TOML or JSON by extension."""
    import os

    from proofs.synthesize import TABLE_FORMATS
    ext = os.path.splitext(text)[1].lower()
    if ext not in TABLE_FORMATS:
        raise argparse.ArgumentTypeError(f"{text}: a table is TOML or JSON "
                                         f"({' or '.join(TABLE_FORMATS)}), not "
                                         f"'{ext or 'no extension'}'")
    return text


def _synthesis_bar(dim: int, system, quiet: bool):
    """The progress bar of one dimension's synthesis (tqdm on stderr, like fperr demo's):
    one step per coefficient lowered (T−, T, T+ and T− raised, per tolerance)."""
    from tqdm import tqdm

    from proofs.synthesize import ORDER
    order = system.order if system is not None else ORDER[dim]
    return tqdm(total=4 * len(order), desc=f"fperr synthesize {dim}D", unit="coefficient",
                leave=False, disable=quiet, file=sys.stderr, mininterval=0.5)
