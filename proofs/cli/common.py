"""What every subcommand of ``fperr`` shares: the help formatter, the one-line error,
the argparse types of paths and numbers."""
from __future__ import annotations

import argparse
import sys

RAW = argparse.RawDescriptionHelpFormatter


def error(command: str, e: Exception) -> int:
    """Print ``fperr COMMAND: error: ...`` on stderr; exit status 2 (bad input)."""
    print(f"fperr {command}: error: {e}", file=sys.stderr)
    return 2


def at_least(k: int):
    """argparse type: an integer ≥ k (one message for every bound)."""
    def check(text: str) -> int:
        n = _integer(text)
        if n < k:
            raise argparse.ArgumentTypeError(f"must be at least {k}, got {n}")
        return n

    check.__name__ = f"at_least_{k}"
    return check


_at_least_0, _at_least_1, _at_least_2 = at_least(0), at_least(1), at_least(2)


def _integer(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None


def _partitions(text: str):
    """A number of partitions (≥ 1) or "auto"."""
    return text if text == "auto" else _at_least_1(text)


def _seconds(text: str) -> float:
    """A time limit: a number of seconds > 0."""
    try:
        t = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of seconds: {text!r}") from None
    if not t > 0:
        raise argparse.ArgumentTypeError(f"must be more than 0 seconds, got {text}")
    return t


def _output_file(text: str) -> str:
    """argparse type of a file to write: its directory must exist ("-": stdout)."""
    from pathlib import Path
    path = Path(text)
    if text != "-" and path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a directory, not a file")
    if text != "-" and not path.resolve().parent.is_dir():
        raise argparse.ArgumentTypeError(
            f"directory {path.parent} does not exist (create it first)")
    return text


def output_as(*extensions: str, what: str, stdout: bool = False):
    """argparse type of a file written in a format its name says: ``extensions`` (with
    the dot) are the formats the option writes, ``what`` names them in the message;
    ``stdout``: "-" is accepted too. Checked when the arguments are parsed, so a name
    the command would not honour is refused (exit 2) before any work."""
    def check(text: str) -> str:
        import os

        if text == "-":
            if stdout:
                return text
            raise argparse.ArgumentTypeError(f"'-' (stdout) is not accepted for {what}: "
                                             f"give a file name ending in "
                                             f"{' or '.join(extensions)}")
        _output_file(text)  # its directory first: the likelier mistake
        ext = os.path.splitext(text)[1].lower()
        if ext not in extensions:
            raise argparse.ArgumentTypeError(
                f"{text}: {what} is written as {' or '.join(extensions)}"
                + (" (or '-' for stdout)" if stdout else "")
                + f", not '{ext or 'no extension'}': name the file accordingly")
        return text

    return check


def user_systems(args, command: str):
    """The declarations of --predicates MODULE for the selected dimensions, or an exit
    status (2) after printing why they cannot be used."""
    from proofs.user_predicates import DeclarationError, load
    try:
        decls = load(args.predicates)
    except DeclarationError as e:
        print(f"fperr {command}: {e}", file=sys.stderr)
        return 2
    chosen = [d for d in decls if not args.dim or d.dim in args.dim]
    if not chosen:
        print(f"fperr {command}: {args.predicates} declares no "
              f"{'/'.join(f'{d}D' for d in sorted(set(args.dim)))} predicates "
              f"(it has {', '.join(f'{d.dim}D' for d in decls)})", file=sys.stderr)
        return 2
    return {d.dim: d for d in chosen}
