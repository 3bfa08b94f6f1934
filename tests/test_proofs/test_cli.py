"""The command-line module (issue 9, item 5), through real processes: ``python -m fperr``,
``--version``, lazy imports, a closed pipe, argument errors, and argparse only in
the ``proofs.cli`` package."""
from __future__ import annotations

import ast
import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def _run(*args: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, *args], cwd=ROOT, env=ENV, capture_output=True,
                          text=True, timeout=300, **kw)


def test_python_m_fperr_help_lists_every_command():
    r = _run("-m", "fperr", "--help")
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("usage: fperr ")
    for cmd in ("tables", "intersect", "demo", "verify", "audit"):
        assert f"    {cmd}" in r.stdout
    assert r.stderr == ""


def test_version_is_the_package_version():
    import fperr

    r = _run("-m", "fperr", "--version")
    assert r.returncode == 0, r.stderr
    # first line: fperr's version; then Python's and the libraries' (for bug reports)
    assert r.stdout.strip().splitlines()[0] == f"fperr {fperr.__version__}"


def test_intersect_help_does_not_import_sympy():
    code = ("import sys\n"
            "from proofs.cli import main\n"
            "try:\n"
            "    main(['intersect', '--help'])\n"
            "except SystemExit as e:\n"
            "    assert e.code == 0, e.code\n"
            "print('sympy' in sys.modules, 'numpy' in sys.modules, 'predicates' in sys.modules)\n")
    r = _run("-c", code)
    assert r.returncode == 0, r.stderr
    *helptext, last = r.stdout.strip().splitlines()
    assert last == "False False False"
    assert any("--naive" in line for line in helptext)


@pytest.mark.parametrize("reader", ["head -1", "true"])
def test_closed_pipe_ends_quietly(reader):
    """``fperr tables | head -1``: no BrokenPipeError traceback. With ``true`` the pipe
    is closed before fperr writes (imports take far longer than ``true``), so the
    BrokenPipeError path is certainly taken and gives 141 (128 + SIGPIPE)."""
    cmd = f"'{sys.executable}' -m fperr tables | {reader}; echo \"status=${{PIPESTATUS[0]}}\""
    r = subprocess.run(["bash", "-c", cmd], cwd=ROOT, env=ENV, capture_output=True,
                       text=True, timeout=300)
    assert r.stderr == ""  # no traceback, no "Exception ignored"
    status = r.stdout.strip().splitlines()[-1]
    if reader == "true":
        assert status == "status=141"
    else:
        assert r.stdout.splitlines()[0] == "| dim | algorithm | quantity | bound | exact |"
        assert status in ("status=0", "status=141")


@pytest.mark.parametrize("argv, message", [
    (["tables", "--dim", "4"], "invalid choice"),
    (["tables", "--format", "html"], "invalid choice"),
    (["intersect", "only_one.vtu"], "the following arguments are required: CUT"),
    (["intersect", "a.vtu", "b.vtu", "--dtype", "float16"], "invalid choice"),
    (["demo", "--n", "1"], "must be at least 2"),
    (["demo", "--n", "x"], "not an integer"),
    (["nosuchcommand"], "invalid choice"),
    ([], "required: COMMAND"),
])
def test_bad_arguments_are_argparse_errors(argv, message):
    r = _run("-m", "fperr", *argv)
    assert r.returncode == 2
    assert message in r.stderr and "Traceback" not in r.stderr
    assert r.stderr.startswith("usage: fperr")


def test_demo_out_naming_a_file_is_an_error_not_a_traceback(tmp_path):
    f = tmp_path / "a_file"
    f.write_text("x")
    r = _run("-m", "fperr", "demo", "--out", str(f), "--n", "2", "--quiet")
    assert r.returncode == 2
    assert "fperr demo: error:" in r.stderr and "not a directory" in r.stderr
    assert "Traceback" not in r.stderr
    assert f.read_text() == "x"


def test_help_texts_are_plain_text():
    """No Sphinx markup (:func:, ``x``) in the help of the commands defined here."""
    for cmd in ("tables", "intersect", "demo"):
        r = _run("-m", "fperr", cmd, "--help")
        assert r.returncode == 0, r.stderr
        assert "``" not in r.stdout and ":func:" not in r.stdout and ":mod:" not in r.stdout


def _imports_argparse(path: pathlib.Path) -> bool:
    tree = ast.parse(path.read_text(), str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import) and any(a.name == "argparse" for a in node.names):
            return True
        if isinstance(node, ast.ImportFrom) and node.module == "argparse":
            return True
    return False


def test_library_modules_do_not_import_argparse():
    files = sorted((ROOT / "fperr").rglob("*.py")) + sorted((ROOT / "predicates").rglob("*.py"))
    assert len(files) > 20  # the scan sees the packages (and their subpackages)
    offenders = [str(p.relative_to(ROOT)) for p in files if _imports_argparse(p)]
    assert offenders == []
    assert _imports_argparse(ROOT / "proofs" / "cli" / "common.py")  # the scan detects it
