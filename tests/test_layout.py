"""The packages depend in one direction: solver <- store <- worker and solver <- store <- service,
with the CLI on top; inside the solver, the engines' packages in one direction too: solid SPH
(solver/sph) and the FEM engine (solver/fem) know nothing of each other nor of the FEM-SPH hybrid
(solver/hybrid), which builds on both. Checked on the source: every import statement, at module
level or inside a function, of every module of a package."""

from __future__ import annotations

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PROJECT = ("solver", "store", "service", "worker", "cli", "web")


def imported(package: str) -> dict[str, set[str]]:
    """The top-level names each module of ``package`` imports (relative imports stay inside it)."""
    out = {}
    for path in sorted((ROOT / package).rglob("*.py")):
        names = set()
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names.update(a.name.split(".")[0] for a in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names.add(node.module.split(".")[0])
        out[str(path.relative_to(ROOT))] = names
    return out


def solver_subpackages(sub: str) -> dict[str, set[str]]:
    """The solver subpackages and modules (the X of solver.X) each module of solver/<sub> imports,
    relative imports resolved."""
    out = {}
    for path in sorted((ROOT / "solver" / sub).rglob("*.py")):
        rel = path.relative_to(ROOT).with_suffix("")
        package = list(rel.parts[:-1])  # a module's package; an __init__'s is itself
        names = set()
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                full = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = ".".join(package[:len(package) - node.level + 1]) if node.level else ""
                mod = ".".join(p for p in (base, node.module or "") if p)
                full = [mod] + [f"{mod}.{a.name}" for a in node.names]
            else:
                continue
            names.update(f.split(".")[1] for f in full if f.startswith("solver."))
        out[str(path.relative_to(ROOT))] = names
    return out


def test_sph_and_fem_import_neither_each_other_nor_the_hybrid():
    for sub, banned in (("sph", {"fem", "hybrid"}), ("fem", {"sph", "hybrid"})):
        bad = {f: sorted(names & banned) for f, names in solver_subpackages(sub).items() if names & banned}
        assert not bad, f"solver/{sub} may not import solver/{{{', '.join(sorted(banned))}}}: {bad}"


def test_the_layout_check_sees_relative_imports():
    got = solver_subpackages("hybrid")
    assert {"fem", "sph"} <= set().union(*got.values()), got


def project_imports(package: str) -> dict[str, set[str]]:
    return {f: {n for n in names if n in PROJECT and n != package} for f, names in imported(package).items()}


def test_worker_imports_only_the_store_the_solver_and_the_standard_library():
    allowed = set(sys.stdlib_module_names) | {"store", "solver", "worker", "__future__"}
    bad = {f: sorted(names - allowed) for f, names in imported("worker").items() if names - allowed}
    assert not bad, f"the worker may import only store, solver and the standard library: {bad}"


def test_store_imports_only_the_solver():
    bad = {f: sorted(names - {"solver"}) for f, names in project_imports("store").items() if names - {"solver"}}
    assert not bad, f"the store may depend only on the solver: {bad}"


def test_service_never_imports_the_worker_nor_the_cli():
    # the server launches its workers as processes by module name (python -m worker)
    bad = {f: sorted(names - {"solver", "store"}) for f, names in project_imports("service").items()
           if names - {"solver", "store"}}
    assert not bad, f"the service may depend only on the store and the solver: {bad}"


def test_solver_imports_no_other_package_of_the_project():
    bad = {f: sorted(names) for f, names in project_imports("solver").items() if names}
    assert not bad, f"the solver depends on nothing else of the project: {bad}"


def test_the_server_starts_its_workers_by_module_name():
    text = (ROOT / "service" / "server.py").read_text()
    assert '"-m", "worker"' in text
