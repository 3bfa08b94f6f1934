"""The ``fperr`` command: the command-line module, on top of every layer.

Every option of every subcommand is declared in this package, and only here (one
``_add_<cmd>`` / ``_run_<cmd>`` pair per subcommand: :mod:`.mesh_commands` for the
registration, :mod:`.proof_commands` for the proofs, :mod:`.common` for what they share); the library modules contain no argument parsing, only plain
functions with typed keyword arguments. Each subcommand imports its library inside its
run function, so that ``fperr intersect --help`` loads neither sympy nor numpy.
"""
from __future__ import annotations

import argparse
import os
import sys

from .common import RAW as _RAW

from .mesh_commands import _add_cut, _add_demo, _add_intersect
from .proof_commands import _add_proofs_commands, _add_tables, report_main

__all__ = ["build_parser", "main", "report_main"]

_DESCRIPTION = ("Robust intersections under floating point (Wang, Jiang, Schroeder, Teran),\n"
                "with derived and verified error bounds. 'fperr COMMAND --help' shows the\n"
                "options of a command.\n\n"
                "Exit status: 0 done, 1 a failure the command names (a constraint, a\n"
                "refused or unfinished run) or an internal error (a bug: one line saying\n"
                "so and what to report; --debug adds the traceback), 2 bad arguments or\n"
                "unusable input (one line on stderr, nothing written).")


# -- the command -----------------------------------------------------------------------
#: the subcommands declared here, in the order of "fperr --help"
_NATIVE = (_add_tables, _add_intersect, _add_cut, _add_demo, _add_proofs_commands)


#: the libraries whose versions ``fperr --version`` prints (what a bug report needs)
_REPORTED = ("numpy", "sympy", "mpmath", "meshio", "matplotlib", "dask", "distributed")


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("fperr")
    except PackageNotFoundError:  # run from a source tree that is not installed
        import fperr

        return fperr.__version__


def _versions() -> str:
    """``fperr --version``: fperr's version, then Python's and the libraries' (read from
    the installed metadata: nothing is imported), as a bug report needs them."""
    import platform
    from importlib.metadata import PackageNotFoundError, version

    def one(name):
        try:
            return f"{name} {version(name)}"
        except PackageNotFoundError:
            return f"{name} not installed"

    return (f"fperr {_version()}\nPython {platform.python_version()} "
            f"({platform.system()} {platform.machine()}); "
            + ", ".join(one(n) for n in _REPORTED))


class _Version(argparse.Action):
    """--version, read only when asked (the metadata of every library takes ~60 ms)."""

    def __call__(self, parser, namespace, values, option_string=None):
        print(_versions())
        parser.exit()


def internal_error(command: str | None, exc: BaseException) -> str:
    """The one line of an internal error: an exception no input check expected, so a bug
    in fperr (exit status 1, never 2: the input may well be right)."""
    what = f"{type(exc).__name__}: {exc}".splitlines()[0]
    return (f"fperr {command or ''}".rstrip() + f": internal error (a bug in fperr, not in "
            f"your input): {what}. Please report it with the command line, the output of "
            f"'fperr --version' and the input files; --debug (before the command) prints "
            f"the traceback")


def build_parser(argv: list[str]) -> argparse.ArgumentParser:
    """The parser of ``fperr`` (no library is imported: each run function imports its own)."""
    parser = argparse.ArgumentParser(prog="fperr", description=_DESCRIPTION,
                                     formatter_class=_RAW)
    parser.add_argument("--version", action=_Version, nargs=0,
                        help="show the versions of fperr, Python and the libraries it uses")
    parser.add_argument("--debug", action="store_true",
                        help="on an internal error (a bug), print the Python traceback "
                             "instead of one line")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in _NATIVE:
        add(sub)
    for p in sub.choices.values():  # its own usage in its errors (main, run functions)
        p.set_defaults(_parser=p)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run ``fperr`` with the arguments ``argv`` (default: the command line); returns
    the exit status. Bad arguments and unusable input: status 2 (argparse's SystemExit,
    or the command's one-line error). An exception no command expected is a bug: status
    1 and one line saying so and what to send (:func:`internal_error`); ``--debug``
    prints its traceback too."""
    argv = sys.argv[1:] if argv is None else list(argv)
    args, extra = build_parser(argv).parse_known_args(argv)
    if extra:  # argparse would name the top level's usage; the command's is the useful one
        args._parser.error(f"unrecognized arguments: {' '.join(extra)}")
    try:
        status = int(args._run(args) or 0)
        sys.stdout.flush()  # a closed pipe shows up here, not at interpreter exit
    except BrokenPipeError:
        # the reader went away (fperr tables | head -1): stop quietly, as Unix tools do;
        # Python would otherwise report the failed flush of stdout again at exit
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141  # 128 + SIGPIPE, the shell's status for a tool killed by the pipe
    except Exception as e:  # not bad input (each command maps those to status 2): a bug
        if args.debug:
            import traceback

            traceback.print_exc()
        print(internal_error(args.command, e), file=sys.stderr)
        return 1
    return status


if __name__ == "__main__":
    sys.exit(main())
