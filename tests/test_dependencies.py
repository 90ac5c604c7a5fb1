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
