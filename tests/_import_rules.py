"""catpose's import rules as data, and the checker that the import-rule test runs.

Every module is in one *unit*: the core (``src/catpose``, imported as ``catpose.*``), ``datasets``,
``methods``, ``configs``, one unit per bench wing (``bench/<wing>/``, imported as
``catpose.bench.<wing>``) and the bench's loose modules (the CLI, ``catpose.bench.cli``). The
checker reads every ``import`` (also those inside functions; relative ones resolved) with
:mod:`ast`, so it sees what the code imports, not what a docstring mentions.

The rules (docs/architecture.md explains them):

- the core imports no other unit; the application layer ``catpose.api`` (``catpose.register``)
  is its own unit and may import the core, configs, datasets and methods (never the bench, never
  Hydra or OmegaConf: :data:`BANNED`), and the package root exports it lazily (:data:`EXCEPTIONS`);
- datasets import only the core; methods import only the core (never a loader, never the bench);
- a bench wing imports the core, datasets, methods, itself and the wings listed in :data:`WINGS`;
  no wing imports the CLI;
- the CLI (the loose modules of ``bench/``) may import anything;
- the protocols run no registration code (:data:`REGISTRATION_FREE`): they list problems and score
  answers, so of the methods they import only the choice rules (arithmetic over stored facts), and
  never Open3D, ``catpose.o3d`` or the ICP kernel;
- the package never reaches the scripts outside it (:data:`OUTSIDE`: the studies in
  ``experiments/``, the maintenance scripts in ``tools/``, the tests): no import of those folders
  or of a script's name there (a sibling import), and none of the ways to load a file that is not
  installed (:data:`FILE_LOADERS`: ``sys.path``, ``runpy``, ``importlib``'s file loaders).
"""

from __future__ import annotations

import ast
from pathlib import Path
from typing import NamedTuple

#: source folder (relative to the repository root) -> its import prefix
ROOTS = {
    "src/catpose": "catpose",
    "datasets": "catpose.datasets",
    "methods": "catpose.methods",
    "configs": "catpose.configs",
    "bench": "catpose.bench",
}

#: bench wing -> the other wings it may import
WINGS: dict[str, frozenset[str]] = {
    "scoring": frozenset(),
    "run": frozenset({"scoring"}),
    "protocols": frozenset({"scoring"}),
    "report": frozenset({"run", "protocols", "scoring"}),
    "interop": frozenset({"run", "protocols", "scoring", "report"}),
    "regress": frozenset({"run", "scoring"}),
    "perf": frozenset({"run"}),
    "category": frozenset({"run", "protocols"}),
    "real": frozenset({"run", "protocols", "scoring"}),
}

#: unit -> the units it may import besides itself and third-party packages (the wings: see WINGS)
LAYERS: dict[str, frozenset[str]] = {
    "core": frozenset(),
    "api": frozenset({"core", "configs", "datasets", "methods"}),
    "configs": frozenset({"core"}),
    "datasets": frozenset({"core"}),
    "methods": frozenset({"core"}),
}


#: unit -> (the only ``catpose.methods`` modules it may import, module prefixes it may never import):
#: the units that run no registration code. ``bench.protocols`` reads the choice rules
#: (``catpose.methods.choice_rules``: NumPy and SciPy over the facts the runner stored) and nothing
#: that registers: no other method module, no Open3D, no ICP kernel.
REGISTRATION_FREE: dict[str, tuple[frozenset[str], tuple[str, ...]]] = {
    "bench.protocols": (
        frozenset({"catpose.methods.choice_rules"}),
        ("open3d", "catpose.o3d", "catpose.point_to_plane_kernel", "teaserpp_python"),
    ),
}


#: unit -> third-party packages it never imports: the library stands without the bench's Hydra
BANNED: dict[str, tuple[str, ...]] = {"api": ("hydra", "omegaconf")}


def registration_free(source: str, module: str) -> bool:
    """Whether unit ``source`` may import ``module`` under :data:`BANNED` and :data:`REGISTRATION_FREE`
    (units not listed: yes)."""
    if any(module == p or module.startswith(p + ".") for p in BANNED.get(source, ())):
        return False
    if source not in REGISTRATION_FREE:
        return True
    methods, forbidden = REGISTRATION_FREE[source]

    def under(prefix: str) -> bool:
        return module == prefix or module.startswith(prefix + ".")

    if any(under(p) for p in forbidden):
        return False
    return not under("catpose.methods") or any(under(m) for m in methods)


#: (importing module, imported unit) pairs allowed against the rules: the package root's lazy
#: ``catpose.register`` (``catpose.__getattr__`` imports ``catpose.api`` on first use)
EXCEPTIONS: frozenset[tuple[str, str]] = frozenset({("catpose", "api")})


#: folders (relative to the repository root) whose scripts the package never imports
OUTSIDE = ("experiments", "tools", "tests")

#: names through which code loads a file that is not an installed module (``sys.path`` as the
#: attribute ``path`` of ``sys``); the package uses none of them
FILE_LOADERS = frozenset({"runpy", "run_path", "run_module", "spec_from_file_location", "SourceFileLoader"})


def outside_names(root: Path) -> frozenset[str]:
    """The top-level names an import of a script outside the package would use: the folders of
    :data:`OUTSIDE`, every folder under them and every script's stem there (``from why_wrong import
    ...`` after a ``sys.path`` insert)."""
    names = set(OUTSIDE)
    for folder in OUTSIDE:
        for p in (Path(root) / folder).rglob("*"):
            if p.suffix == ".py" or p.is_dir():
                names.add(p.stem if p.suffix == ".py" else p.name)
    return frozenset(n for n in names if n.isidentifier() and n != "__init__")


def file_loads(tree: ast.AST) -> list[tuple[int, str]]:
    """(line, what) of every use of :data:`FILE_LOADERS` in ``tree``: an import of one, an attribute
    or name spelling one, and ``sys.path``."""
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            if node.attr in FILE_LOADERS:
                out.append((node.lineno, node.attr))
            elif node.attr == "path" and isinstance(node.value, ast.Name) and node.value.id == "sys":
                out.append((node.lineno, "sys.path"))
        elif isinstance(node, ast.Name) and node.id in FILE_LOADERS:
            out.append((node.lineno, node.id))
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names = [a.name for a in node.names] + (
                [node.module] if isinstance(node, ast.ImportFrom) and node.module else []
            )
            out += [(node.lineno, n) for n in names if set(n.split(".")) & FILE_LOADERS]
    return out


class Violation(NamedTuple):
    path: str  #: file, relative to the root checked
    line: int
    source: str  #: the importing unit
    target: str  #: the imported module

    def __str__(self) -> str:
        return f"{self.path}:{self.line}: {self.source} imports {self.target}"


def unit_of(module: str) -> str | None:
    """The unit of a dotted module name (None: not catpose's)."""
    parts = module.split(".")
    if parts[0] != "catpose":
        return None
    if len(parts) == 1:
        return "core"
    if parts[1] in ("datasets", "methods", "configs", "api"):
        return parts[1]
    if parts[1] == "bench":
        return f"bench.{parts[2]}" if len(parts) > 2 and parts[2] in WINGS else "bench"
    return "core"


def allowed(source: str, target: str) -> bool:
    """Whether unit ``source`` may import unit ``target``."""
    if source == target:
        return True
    if source == "bench":  # the CLI
        return True
    if source.startswith("bench."):
        if target.startswith("bench."):
            return target.removeprefix("bench.") in WINGS[source.removeprefix("bench.")]
        return target in ("core", "datasets", "methods", "configs")
    return target in LAYERS[source]


def module_name(root: Path, path: Path) -> str | None:
    """The dotted name a file is imported as (None: outside the source folders)."""
    rel = path.relative_to(root).with_suffix("")
    for folder, prefix in ROOTS.items():
        parts = Path(folder).parts
        if rel.parts[: len(parts)] == parts:
            rest = rel.parts[len(parts) :]
            if rest and rest[-1] == "__init__":
                rest = rest[:-1]
            return ".".join((prefix, *rest))
    return None


def imported_modules(tree: ast.AST, module: str, is_package: bool) -> list[tuple[int, str]]:
    """(line, module) of every import in ``tree``; ``from X import y`` counts as ``X.y`` (y may be
    a module: ``from catpose.bench.run import runner``); relative imports resolved against
    ``module``."""
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                package = module.split(".") if is_package else module.split(".")[:-1]
                package = package[: len(package) - (node.level - 1)]
                base = ".".join([*package, base] if base else package)
            out += [(node.lineno, f"{base}.{a.name}") for a in node.names]
    return out


def check_tree(root: Path) -> list[Violation]:
    """Every import under ``root``'s source folders that breaks a rule."""
    root = Path(root)
    found = []
    outside = outside_names(root)
    for folder in ROOTS:
        for path in sorted((root / folder).rglob("*.py")):
            module = module_name(root, path)
            source = unit_of(module) if module else None
            if source is None:
                continue
            tree = ast.parse(path.read_text(), filename=str(path))
            for line, target_module in imported_modules(tree, module, path.name == "__init__.py"):
                target = unit_of(target_module)
                if (
                    target is not None and not allowed(source, target) and (module, target) not in EXCEPTIONS
                ) or not registration_free(source, target_module):
                    found.append(Violation(path.relative_to(root).as_posix(), line, source, target_module))
                elif target is None and target_module.split(".")[0] in outside:  # a script outside the package
                    found.append(Violation(path.relative_to(root).as_posix(), line, source, target_module))
            found += [
                Violation(path.relative_to(root).as_posix(), line, source, what) for line, what in file_loads(tree)
            ]
    return found
