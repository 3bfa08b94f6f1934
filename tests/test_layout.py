"""The test tree mirrors the packages (issue 9, item 6): every test module lives in the
folder of the package it tests, shared helpers live in tests/support, and no test module
imports another test module (each one can be read, moved and run on its own)."""
import ast
import re
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


# -- the packages' architecture (docs/design.md, "Map of the layers") --------------------------
ROOT = TESTS.parent
PACKAGES = ("fperr", "predicates", "proofs")
LAYER = {"fperr": 0, "predicates": 1, "proofs": 2}


def _modules() -> dict[str, pathlib.Path]:
    """{dotted module name: path} of every module of the three packages."""
    out = {}
    for pkg in PACKAGES:
        for p in sorted((ROOT / pkg).rglob("*.py")):
            if "__pycache__" in p.parts:
                continue
            parts = list(p.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(parts)] = p
    return out


def _walk_outside_main(tree):
    """ast.walk, skipping ``if __name__ == "__main__":`` blocks (a script's entry point,
    run as ``__main__``, not an import of the module) and ``if TYPE_CHECKING:`` blocks
    (annotations, never run)."""
    todo = [tree]
    while todo:
        node = todo.pop()
        if isinstance(node, ast.If) and ("__main__" in ast.unparse(node.test)
                                         or ast.unparse(node.test) == "TYPE_CHECKING"):
            todo.extend(node.orelse)
            continue
        yield node
        todo.extend(ast.iter_child_nodes(node))


def _import_graph() -> dict[str, set[str]]:
    """module -> the project modules it imports, at any depth of the file (a lazy import
    inside a function is an arrow too), including the packages whose ``__init__`` an
    import runs (importing a.b.c runs a and a.b)."""
    mods = _modules()
    graph = {}
    for name, path in mods.items():
        is_pkg = path.name == "__init__.py"
        here = name.split(".") if is_pkg else name.split(".")[:-1]
        edges = set()
        for node in _walk_outside_main(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    base = ".".join(here[: len(here) - node.level + 1] + ([base] if base else []))
                targets = [base] + [f"{base}.{a.name}" for a in node.names]
            for t in targets:
                parts = t.split(".")
                for i in range(1, len(parts) + 1):  # the module and the packages it runs
                    m = ".".join(parts[:i])
                    if m in mods and m != name and not name.startswith(m + "."):
                        edges.add(m)
        graph[name] = edges
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan, iterative)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                elif w in on:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    out.append(sorted(comp))
    return out


def test_no_import_cycle():
    graph = _import_graph()
    assert len(graph) > 80 and sum(map(len, graph.values())) > 150  # the scan sees the tree
    assert _cycles(graph) == []


def test_the_cycle_finder_finds_cycles():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_imports_point_down_the_layers():
    """fperr knows no geometry; predicates uses fperr; proofs (and the command line in
    it) uses both: no arrow from a lower layer to a higher one. ``python -m fperr``
    (``fperr.__main__``) is the command line's entry point, on top of everything."""
    up = sorted((a, b) for a, bs in _import_graph().items() for b in bs
                if LAYER[b.split(".")[0]] > LAYER[a.split(".")[0]]
                and not a.endswith(".__main__"))
    assert not up, f"imports pointing up the layers: {up}"


def test_modules_and_functions_are_small():
    """Modules of at most 450 lines, functions of at most 80."""
    big = []
    for name, path in _modules().items():
        text = path.read_text(encoding="utf-8")
        if len(text.splitlines()) > 450:
            big.append(f"{name}: {len(text.splitlines())} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > 80:
                    big.append(f"{name}.{node.name}: {n} lines")
    assert not big, big


def test_code_cites_the_docs_not_issue_numbers():
    """A reader of the code cannot follow 'issue 12': cite the paper or docs/*.md."""
    pattern = re.compile(r"\bissues? #?\d", re.I)
    hits = [f"{name}:{i}" for name, path in _modules().items()
            for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
            if pattern.search(line)]
    assert not hits, hits
