"""The README's code runs as written (so it cannot rot)."""
import pathlib
import re

import numpy as np

README = pathlib.Path(__file__).resolve().parents[1] / "README.md"


def test_readme_python_blocks_run(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the examples write files
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
    assert blocks
    env: dict = {}
    for code in blocks:
        exec(compile(code, str(README), "exec"), env)
    out = capsys.readouterr().out
    assert "R ≤ 5ε, E ≤ 9εL^2" in out
    assert env["hit"].shape == (10**6,) and env["w"].shape == (10**6, 4)
    assert env["res"]["vertex_vertex"].sim.shape == (81, 1)  # (n+1)² for n = 8
    assert (tmp_path / "cut.vtu").stat().st_size > 0
    # the cut: two halves, then a quarter off one (sums of 1/3072 per tetrahedron)
    assert env["sm"].n_pieces == 2
    assert np.allclose(env["cm"].piece_volumes(), [0.5, 0.5], rtol=0, atol=1e-12)
    assert np.allclose(sorted(env["cm2"].piece_volumes()), [0.25, 0.25, 0.5], rtol=0, atol=1e-12)
    assert (tmp_path / "pieces.vtu").stat().st_size > 0


def test_readme_quick_start_matches_ci():
    text = README.read_text()
    ci = (README.parent / ".ci" / "run").read_text()
    test_line = "python3 -m pip install -e '.[test]' && python3 -m pytest -q -n auto"
    assert test_line in text
    assert test_line in ci


def test_design_map_lists_every_module():
    """docs/design.md's map of the layers names every module and subpackage of the three
    packages (a module added without its line fails here), and nothing that is gone."""
    root = README.parent
    text = (root / "docs" / "design.md").read_text().split("\n## ", 2)[1]
    assert text.startswith("Map of the layers")
    listed = set(re.findall(r"^\s*- `([\w.]+/?)`", text, re.M))
    actual = set()
    for pkg in ("fperr", "predicates", "proofs"):
        actual.add(pkg + "/")
        for p in (root / pkg).rglob("*"):
            if "__pycache__" in p.parts or p.name == "__init__.py":
                continue
            if p.is_dir():
                actual.add(p.name + "/")
            elif p.suffix == ".py":
                actual.add(p.name)
    assert listed == actual


def test_quick_start_works_without_global_installs():
    """Issue 11: a venv line for systems that refuse global pip installs, .venv/ ignored,
    py.typed shipped as package data."""
    import tomllib

    text = README.read_text()
    assert "python3 -m venv .venv && . .venv/bin/activate && python3 -m pip install ." in text
    root = README.parent
    assert ".venv/" in (root / ".gitignore").read_text().splitlines()
    data = tomllib.loads((root / "pyproject.toml").read_text())
    pkg_data = data["tool"]["setuptools"]["package-data"]
    for pkg in ("fperr", "predicates", "proofs"):
        assert (root / pkg / "py.typed").is_file()
        assert "py.typed" in pkg_data[pkg]
