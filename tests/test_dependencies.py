"""dependencies point down. The BIARM method does not import its baselines (an
architecture it does not train is looked up in :mod:`evodevo.trainers`), and no library module
imports the command line (``parse_seeds`` lives in :mod:`evodevo.seeding`)."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "evodevo"


def _imports(path: Path) -> set[str]:
    """Every module a file imports, at the top or inside functions."""
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
    return out


def _offenders(package: str, forbidden: str) -> list[str]:
    return [
        f"{p.relative_to(SRC)} imports {m}"
        for p in sorted((SRC / package).rglob("*.py") if package else SRC.rglob("*.py"))
        if not (not package and p.relative_to(SRC).parts[0] in ("cli", "__main__.py"))
        for m in sorted(_imports(p))
        if m == forbidden or m.startswith(forbidden + ".")
    ]


def test_the_method_does_not_import_its_baselines():
    assert _offenders("neuromod", "evodevo.baselines") == []


def test_library_code_does_not_import_the_cli():
    assert _offenders("", "evodevo.cli") == []


def test_the_sb3_trainer_is_registered_by_the_baselines():
    import evodevo.baselines
    from evodevo.neuromod.variants import get_variant
    from evodevo.trainers import get_trainer

    assert get_trainer(get_variant("sb3-dqn").architecture) is evodevo.baselines.train_sb3_dqn
    assert get_trainer(get_variant("biarm").architecture) is None


def test_an_unregistered_architecture_names_what_to_import():
    from evodevo.errors import EvodevoError
    from evodevo.trainers import get_trainer

    with pytest.raises(EvodevoError, match="import evodevo.baselines"):
        get_trainer("no-such-architecture")


_STRING_IMPORT = re.compile(r'"evodevo(\.[a-z_0-9]+)+:[A-Za-z_]')


def test_no_module_of_the_package_is_named_in_a_string():
    """Dependencies are imports: no ``"evodevo.x:attr"`` path for a registry to import, except
    Gymnasium's entry points (its own registration API, in evodevo/envs/__init__.py)."""
    hits = [
        f"{p.relative_to(SRC)}:{i}"
        for p in sorted(SRC.rglob("*.py"))
        if p.relative_to(SRC).as_posix() != "envs/__init__.py"
        for i, line in enumerate(p.read_text().splitlines(), 1)
        if _STRING_IMPORT.search(line) and not line.lstrip().startswith(("*", "#", ">>>"))
    ]
    assert hits == []


def test_a_fresh_process_loads_a_baseline_run_through_evodevo_load():
    """Nothing but ``import evodevo``: the loader of baseline runs is registered by the import
    of evodevo.baselines that evodevo.policy makes (no module looked up by name)."""
    pytest.importorskip("stable_baselines3")
    run = SRC.parents[1] / "docs" / "results" / "grn_vision" / "ppo_blob_s0"
    code = f"import evodevo; p = evodevo.load({str(run)!r}); assert p.kind == 'ppo', p.kind"
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


def _module_graph() -> dict[str, set[str]]:
    """Module -> the package modules it imports, at the top or inside functions (imports under
    ``if TYPE_CHECKING:`` excluded: they never run)."""
    mods = {}
    for p in SRC.rglob("*.py"):
        parts = ("evodevo", *p.relative_to(SRC).with_suffix("").parts)
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        mods[name] = p

    def resolve(name: str) -> str:
        while name and name not in mods:
            name = name.rpartition(".")[0]
        return name

    graph: dict[str, set[str]] = {m: set() for m in mods}
    for m, p in mods.items():
        tree = ast.parse(p.read_text())
        typing_only = {
            id(k)
            for n in ast.walk(tree)
            if isinstance(n, ast.If) and "TYPE_CHECKING" in ast.unparse(n.test)
            for k in ast.walk(n)
        }
        pkg = m if p.name == "__init__.py" else m.rpartition(".")[0]
        for n in ast.walk(tree):
            if id(n) in typing_only:
                continue
            if isinstance(n, ast.Import):
                targets = [a.name for a in n.names]
            elif isinstance(n, ast.ImportFrom):
                base = n.module or ""
                if n.level:
                    up = pkg.split(".")[: len(pkg.split(".")) - (n.level - 1)]
                    base = ".".join([*up, base] if base else up)
                targets = [f"{base}.{a.name}" for a in n.names]
            else:
                continue
            for t in targets:
                if t.startswith("evodevo") and resolve(t) not in ("", m):
                    graph[m].add(resolve(t))
    return graph


def test_the_import_graph_has_no_cycle_counting_imports_inside_functions():
    graph = _module_graph()
    state: dict[str, int] = {}
    cycles: list[list[str]] = []

    def visit(m: str, path: list[str]) -> None:
        state[m] = 1
        for n in sorted(graph[m]):
            if state.get(n) == 1:
                cycles.append([*path[path.index(n) :], n])
            elif n not in state:
                visit(n, [*path, n])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
    assert cycles == [], " ; ".join(" -> ".join(c) for c in cycles)
    assert len(graph) > 100 and sum(map(len, graph.values())) > 300  # the walk saw the package


#: Heavy libraries (each 0.3-1.2 s to import) that the command line, the run layer and the
#: workers' modules import only where they are used: rliable (pandas, arch), matplotlib, cma
#: and scipy.stats. Every CLI call and every spawned worker would otherwise pay them.
HEAVY_ON_USE = ("rliable", "matplotlib", "cma", "scipy.stats", "pandas")


@pytest.mark.parametrize(
    "module",
    [
        "evodevo.cli",
        "evodevo.neuromod.compare",
        "evodevo.grn.evolution",
        "evodevo.grn.evaluator",
        "evodevo.evidence",
    ],
)
def test_importing_a_module_leaves_the_heavy_libraries_for_later(module: str):
    code = f"import sys, {module}; print(sorted(m for m in {HEAVY_ON_USE!r} if m in sys.modules))"
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    ).stdout.strip()
    assert out == "[]", f"importing {module} imported {out}"
