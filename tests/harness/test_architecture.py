"""The house rules of ARCHITECTURE.md, checked on the source tree: small modules, a core that
finds engines and cases only through the registry, and no engine or case name in the core."""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MAX_LINES = 400
ENGINE_PACKAGES = ("pybullet", "mujoco", "pymunk", "taichi")


def _modules(*dirs):
    return sorted(p for d in dirs for p in (ROOT / d).rglob("*.py"))


def _names(kind: str) -> list[str]:
    from refsim.registry import entries
    return [n for n, e in entries(kind).items() if e.origin.startswith("refsim ")]


@pytest.mark.parametrize("path", _modules("refsim", "adapters", "cases", "benchmarks"),
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_module_is_under_400_lines(path):
    assert len(path.read_text().splitlines()) <= MAX_LINES


def _imported(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            out.add(node.module.split(".")[0])
    return out


def test_only_the_registry_imports_adapters_or_cases():
    plugins = {"refsim_adapters", "refsim_cases", "adapters", "cases"}
    offenders = {str(p.relative_to(ROOT)): sorted(_imported(p) & plugins)
                 for p in _modules("refsim") if p.name != "registry.py"}
    assert {k: v for k, v in offenders.items() if v} == {}


def test_installed_refsim_adds_no_generic_top_level_names(tmp_path):
    """Outside the repository (no folder on the path), the installed refsim provides
    refsim_adapters, refsim_cases and refsim_benchmarks, and no `adapters`, `cases` or
    `benchmarks` (the folders' own names, which any other distribution might use)."""
    import subprocess
    import sys
    code = ("import importlib.util as u; print([n for n in ('adapters', 'cases', "
            "'benchmarks', 'refsim_adapters', 'refsim_cases', 'refsim_benchmarks') "
            "if u.find_spec(n) is not None])")
    found = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                           text=True, check=True).stdout.strip()
    assert found == "['refsim_adapters', 'refsim_cases', 'refsim_benchmarks']"


def test_core_imports_no_engine_package():
    offenders = {str(p.relative_to(ROOT)): sorted(_imported(p) & set(ENGINE_PACKAGES))
                 for p in _modules("refsim")}
    assert {k: v for k, v in offenders.items() if v} == {}


def _string_constants(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    docstrings = {id(n.body[0].value) for n in ast.walk(tree)
                  if isinstance(n, (ast.Module, ast.FunctionDef, ast.ClassDef))
                  and n.body and isinstance(n.body[0], ast.Expr)
                  and isinstance(n.body[0].value, ast.Constant)}
    return {n.value for n in ast.walk(tree) if isinstance(n, ast.Constant)
            and isinstance(n.value, str) and id(n) not in docstrings}


def test_no_engine_or_case_name_in_core_code():
    """Code strings (not docstrings or comments) never name a built-in case or engine; the
    in-house engine shares its name with the package, so only comparisons with it count."""
    names = set(_names("case")) | (set(_names("engine")) - {"refsim"})
    found = {}
    for path in _modules("refsim"):
        hits = {s for s in _string_constants(path) for n in names
                if re.search(rf"(?<![\w.]){re.escape(n)}(?![\w])", s)}
        source = path.read_text()
        if re.search(r"""==\s*["']refsim["']|["']refsim["']\s*==""", source):
            hits.add("== 'refsim'")
        if hits:
            found[str(path.relative_to(ROOT))] = sorted(hits)
    assert found == {}


def test_every_builtin_engine_and_case_comes_from_an_entry_point():
    assert set(_names("engine")) >= {"refsim", *ENGINE_PACKAGES}
    assert len(_names("case")) >= 8
