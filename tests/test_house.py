"""The house's rules, read from the syntax trees (tools/structure.py): imports run one way
(terrain <- planner <- replay <- terrapath), no private name is imported across modules,
replay/'s top level stays small (each concept in its room), and no avoider imports another."""

from __future__ import annotations

from pathlib import Path

from tools.structure import (
    PACKAGES,
    edges,
    module_imports,
    module_name,
    package_files,
    private_imports,
    top_level,
)

ROOT = Path(__file__).resolve().parents[1]


def test_imports_run_one_way_only() -> None:
    rank = {pkg: k for k, pkg in enumerate(PACKAGES)}  # terrain, planner, replay, terrapath
    upward = [
        f"{me} imports {mod}"
        for path in package_files(ROOT)
        for me, mod, _ in module_imports(path, ROOT)
        if rank[mod.split(".")[0]] > rank[me.split(".")[0]]
    ]
    assert upward == []


def test_no_private_name_is_imported_across_modules() -> None:
    assert private_imports(ROOT) == []


def test_replay_keeps_few_modules_at_its_top_level() -> None:
    assert len(top_level(ROOT)) <= 8, top_level(ROOT)


def test_no_avoider_imports_another() -> None:
    avoiders = ("pso_ca", "ctga", "fga", "priority")

    def family(module: str) -> str | None:
        name = module.removeprefix("replay.avoidance.")
        if module == name:
            return None
        return next((a for a in avoiders if name == a or name.startswith(a + "_")), None)

    crossing = []
    for edge in edges(ROOT):
        me, mod = edge.split(" -> ")
        a, b = family(me), family(mod)
        # an avoider's own modules (fga_plan, pso_ca_geometry, ...) are its family; FGA's cone
        # geometry is shared (PSO-CA reads its encounter test), so it belongs to no one
        if a and b and a != b and mod != "replay.avoidance.fga_geometry":
            crossing.append(edge)
    assert crossing == []


def test_the_module_names_come_from_the_paths() -> None:
    assert module_name(ROOT / "replay" / "avoidance" / "__init__.py", ROOT) == "replay.avoidance"
    assert module_name(ROOT / "replay" / "sim.py", ROOT) == "replay.sim"


def test_the_suites_longest_first_order_names_existing_files() -> None:
    from tests.conftest import LONGEST_FIRST

    here = Path(__file__).resolve().parent
    missing = [name for name in LONGEST_FIRST if not (here / name).is_file()]
    assert not missing, f"tests/conftest.py LONGEST_FIRST names files that are gone: {missing}"
    assert len(set(LONGEST_FIRST)) == len(LONGEST_FIRST)
