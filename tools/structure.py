"""The shape of the code, read from its syntax trees (nothing is imported): the longest functions,
the modules at replay/'s top level, private names imported across modules, and the import edges
between replay's modules. Run it from the checkout's root:

    python -m tools.structure                 # all four reports
    python -m tools.structure --longest 25    # the 25 longest functions only
    python -m tools.structure --edges > build/edges.txt   # diff two checkouts' edges

A function's length counts its lines from ``def`` to its last line (docstring included); a
method is named ``Class.method``. A private name is one starting with ``_`` (a module or a
name in it) imported by ``from X import _name`` or ``import X._mod`` from another module;
``__future__`` and dunder names do not count.
"""

from __future__ import annotations

import argparse
import ast
from collections.abc import Iterator
from pathlib import Path

PACKAGES = ("terrain", "planner", "replay", "terrapath")


def package_files(root: Path) -> Iterator[Path]:
    for pkg in PACKAGES:
        yield from sorted((root / pkg).rglob("*.py"))


def module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _walk(node: ast.AST, prefix: str, rel: str, out: list[tuple[int, str]]) -> None:
    for child in ast.iter_child_nodes(node):
        if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
            n = (child.end_lineno or child.lineno) - child.lineno + 1
            out.append((n, f"{rel}:{child.lineno} {prefix}{child.name}"))
            _walk(child, f"{prefix}{child.name}.", rel, out)
        elif isinstance(child, ast.ClassDef):
            _walk(child, f"{prefix}{child.name}.", rel, out)


def functions(root: Path) -> list[tuple[int, str]]:
    """(length, 'path:line Qual.name') of every function and method."""
    out: list[tuple[int, str]] = []
    for path in package_files(root):
        tree = ast.parse(path.read_text(), str(path))
        _walk(tree, "", str(path.relative_to(root)), out)
    return sorted(out, reverse=True)


def module_imports(path: Path, root: Path) -> Iterator[tuple[str, str, list[str]]]:
    """(importing module, imported module, names) of every absolute import of our packages."""
    me = module_name(path, root)
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module.split(".")[0] in PACKAGES:
                yield me, node.module, [a.name for a in node.names]
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] in PACKAGES:
                    yield me, a.name, []


def private_imports(root: Path) -> list[str]:
    found = []
    for path in package_files(root):
        for me, mod, names in module_imports(path, root):
            private_mod = [
                p for p in mod.split(".") if p.startswith("_") and not p.startswith("__")
            ]
            private_names = [n for n in names if n.startswith("_") and not n.startswith("__")]
            if private_mod or private_names:
                what = ", ".join(private_names) or mod
                found.append(f"{me} imports {what} from {mod}")
    return sorted(found)


def edges(root: Path) -> list[str]:
    """``a -> b`` for every module of replay importing another of replay (one line each)."""
    out = set()
    for path in package_files(root):
        for me, mod, _ in module_imports(path, root):
            if me.startswith("replay") and mod.startswith("replay") and me != mod:
                out.add(f"{me} -> {mod}")
    return sorted(out)


def top_level(root: Path) -> list[str]:
    return sorted(p.name for p in (root / "replay").glob("*.py") if p.name != "__init__.py")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", type=Path, default=Path.cwd())
    ap.add_argument("--longest", type=int, metavar="N", help="the N longest functions only")
    ap.add_argument("--edges", action="store_true", help="replay's import edges only")
    args = ap.parse_args(argv)
    root = args.root.resolve()
    if args.edges:
        print("\n".join(edges(root)))
        return 0
    fns = functions(root)
    n = args.longest or 15
    print(
        f"longest functions ({len(fns)} in all, {sum(1 for k, _ in fns if k > 100)} over 100 lines):"
    )
    for k, name in fns[:n]:
        print(f"  {k:4d}  {name}")
    if args.longest:
        return 0
    mods = top_level(root)
    print(f"\nreplay/ top-level modules ({len(mods)}): {' '.join(mods)}")
    priv = private_imports(root)
    print(f"\nprivate names imported across modules ({len(priv)}):")
    for line in priv:
        print(f"  {line}")
    print(f"\nimport edges inside replay/: {len(edges(root))}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
