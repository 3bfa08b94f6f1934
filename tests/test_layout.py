"""The test tree mirrors the packages (issue 9, item 6): every test module lives in the
folder of the package it tests, shared helpers live in tests/support, and no test module
imports another test module (each one can be read, moved and run on its own)."""
import ast
import pathlib

TESTS = pathlib.Path(__file__).resolve().parent
FOLDERS = {"test_fperr", "test_predicates", "test_registration", "test_proofs"}
TOP = {"test_readme.py", "test_layout.py"}


def _test_modules() -> list[pathlib.Path]:
    return sorted(p for p in TESTS.rglob("test_*.py") if "__pycache__" not in p.parts)


def _imported_names(path: pathlib.Path) -> set[str]:
    """Top-level module names imported anywhere in ``path`` (also inside functions)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def test_every_test_module_is_in_a_package_folder():
    modules = _test_modules()
    assert len(modules) >= 30 and {p.parent.name for p in modules} >= FOLDERS  # scan works
    misplaced = [str(p.relative_to(TESTS)) for p in modules
                 if not (p.parent == TESTS and p.name in TOP)
                 and not (p.parent.parent == TESTS and p.parent.name in FOLDERS)]
    assert not misplaced, f"test modules outside {sorted(FOLDERS)}: {misplaced}"
    # prepend import mode needs unique basenames; no folder may be named like a package
    names = [p.name for p in modules]
    assert len(names) == len(set(names)), "two test modules share a basename"
    assert not {p.name for p in TESTS.iterdir()} & {"fperr", "predicates", "proofs"}


def test_no_test_module_imports_another():
    offenders = {}
    for path in _test_modules() + sorted((TESTS / "support").glob("*.py")) \
            + sorted((TESTS / "fixtures").glob("*.py")) + [TESTS / "conftest.py"]:
        bad = sorted(n for n in _imported_names(path) if n.startswith("test_"))
        if bad:
            offenders[str(path.relative_to(TESTS))] = bad
    assert not offenders, f"import shared code from tests/support instead: {offenders}"


def test_import_scan_detects_a_test_import(tmp_path):
    """The scan above is not vacuous: both import forms are caught."""
    p = tmp_path / "test_x.py"
    p.write_text("import os\ndef f():\n    from test_y import z\nimport test_w.sub\n")
    assert {n for n in _imported_names(p) if n.startswith("test_")} == {"test_y", "test_w"}
