"""DESIGN.md "Which part may know which", stated as an import contract over the whole tree.

Every module of the repository's ``scaling/``, ``solvers/`` and ``studies/`` folders is read
as source (nothing is imported) under its installed name (``hypate.*``; the folder
``scaling/api`` is the top-level package ``hypate``). The rules:

- ``hypate.solvers`` imports nothing of ``hypate.scaling`` or ``hypate.studies``;
- ``hypate.solvers.numerics`` imports nothing else of ``hypate.solvers``;
- ``hypate.scaling.engine`` imports of the project only itself and ``hypate.solvers.numerics``;
- ``hypate.scaling.workflow`` does not import the report or the CLI, the report does not
  import the CLI, and nothing but the CLI imports it;
- the workflow's rooms (:data:`WORKFLOW_ROOMS`: vocabulary, campaigns, analyses) import only
  the rooms before them;
- no import cycles between modules (``TYPE_CHECKING`` imports included: a cycle that only
  type checking sees is still two modules that know each other);
- no import inside a function or class except of an optional dependency (dask), and the
  top-level package's lazy import of its API (``hypate.__getattr__`` -> ``hypate._api``,
  PEP 562: ``import hypate`` stays instant, so the ``hypate`` command can answer Ctrl-C while
  it starts) and the console script's of the command line (``--version`` and ``--help``
  answered first);
- how a study runs is decided by the runner (``hypate.scaling.workflow.campaigns.execute``) only: the
  CLI and the top-level API call it and import none of the ways it chooses between
  (:data:`RUNNERS`);
- no import by string name (``importlib.import_module``, ``__import__``,
  ``pkgutil.resolve_name``) but in :data:`USER_CODE`, the loader of the user's own code;
- no import of another module's private names (``from m import _x``), and no private module
  (``_name``) imported from outside its own package;
- ``pyproject.toml`` lists exactly the packages of the tree.

``check_tree`` is run on the real tree and on a small fabricated one that breaks each rule,
so that the contract is shown to fail when it should.
"""
from __future__ import annotations

import ast
import tomllib
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
#: Repository folder -> installed package name (pyproject.toml, [tool.setuptools] package-dir).
ROOTS = {"scaling/api": "hypate", "scaling": "hypate.scaling", "solvers": "hypate.solvers",
         "studies": "hypate.studies"}
#: Imports allowed inside functions: optional dependencies only.
OPTIONAL = ("dask", "distributed")
#: The lazy imports allowed inside a function: (importer, imported module) -- the top-level
#: package's API, and the console script's command line after --version / --help were
#: answered without it (scaling/cli/commands.py).
LAZY = {("hypate", "hypate._api"),
        ("hypate.scaling.cli.entry", "hypate.scaling.cli.main")}
#: The scaling workflow's rooms in reading order: each imports only the ones before it.
WORKFLOW_ROOMS = ("vocabulary", "campaigns", "analyses")
#: The ways a study runs, which only the runner (``hypate.scaling.workflow.campaigns.execute``)
#: picks: (module, function) pairs the CLI and the top-level API may not import.
RUNNERS = {("hypate.scaling.workflow.campaigns.run", "run_study"),
           ("hypate.scaling.workflow.campaigns.sweep", "run_sweep"),
           ("hypate.scaling.workflow.campaigns.robust", "run_robust_study")}


@dataclass(frozen=True)
class Import:
    importer: str
    target: str          # the imported module (or package) name
    names: tuple[str, ...]
    line: int
    nested: bool         # inside a function or class body


def module_name(path: Path, root: Path) -> str | None:
    """Installed dotted name of the module at ``path`` (None outside the packages)."""
    rel = path.relative_to(root).with_suffix("").as_posix()
    for folder, package in sorted(ROOTS.items(), key=lambda kv: -len(kv[0])):
        if rel == folder or rel.startswith(folder + "/"):
            rest = rel[len(folder):].strip("/").replace("/", ".")
            name = f"{package}.{rest}" if rest else package
            return name[: -len(".__init__")] if name.endswith(".__init__") else name
    return None


def _resolve(module: str, is_package: bool, level: int, target: str | None) -> str:
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (level - 1)] if level > 1 else base
    return ".".join(base + ([target] if target else []))


def imports_of(path: Path, module: str) -> tuple[list[Import], list[str]]:
    """The project imports of one module, and its string-name imports (``file:line``)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    is_package = path.name == "__init__.py"
    found: list[Import] = []
    dynamic: list[str] = []

    def visit(node: ast.AST, nested: bool) -> None:
        for child in ast.iter_child_nodes(node):
            inner = nested or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef,
                                                 ast.ClassDef, ast.Lambda))
            if isinstance(child, ast.Import):
                for alias in child.names:
                    found.append(Import(module, alias.name, (), child.lineno, nested))
            elif isinstance(child, ast.ImportFrom):
                target = (_resolve(module, is_package, child.level, child.module)
                          if child.level else child.module or "")
                found.append(Import(module, target, tuple(a.name for a in child.names),
                                    child.lineno, nested))
            elif isinstance(child, ast.Call):
                fn = child.func
                name = fn.attr if isinstance(fn, ast.Attribute) else getattr(fn, "id", "")
                if name in ("import_module", "__import__", "resolve_name"):
                    dynamic.append(f"{path}:{child.lineno}")
            visit(child, inner)

    visit(tree, False)
    return found, dynamic


def _is_under(name: str, package: str) -> bool:
    return name == package or name.startswith(package + ".")


def _workflow_room(name: str) -> str | None:
    parts = name.split(".")
    if parts[:3] == ["hypate", "scaling", "workflow"] and len(parts) > 3 \
            and parts[3] in WORKFLOW_ROOMS:
        return parts[3]
    return None


def _layer_violation(importer: str, target: str) -> str | None:
    if not _is_under(target, "hypate") or _is_under(importer, target):
        return None
    if _is_under(importer, "hypate.solvers"):
        if not _is_under(target, "hypate.solvers"):
            return "the simulator imports nothing of scaling/ or studies/"
        if _is_under(importer, "hypate.solvers.numerics") and \
                not _is_under(target, "hypate.solvers.numerics"):
            return "solvers.numerics imports nothing else of solvers/"
    if _is_under(importer, "hypate.scaling.engine") and not (
            _is_under(target, "hypate.scaling.engine")
            or _is_under(target, "hypate.solvers.numerics")):
        return "the engine knows only itself and solvers.numerics"
    if _is_under(target, "hypate.scaling.cli") and not _is_under(importer, "hypate.scaling.cli"):
        return "nothing but the CLI imports the CLI"
    if _is_under(importer, "hypate.scaling.workflow") and _is_under(target, "hypate.scaling.report"):
        return "the workflow does not import the report"
    if target == "hypate" and importer != "hypate":
        return "the top-level API is imported by users, not by the project"
    return None


def _project_module(target: str, names: tuple[str, ...], modules: set[str]) -> list[str]:
    """Project modules an import statement loads (``from pkg import mod`` loads pkg.mod)."""
    out = [target] if target in modules else []
    out += [f"{target}.{n}" for n in names if f"{target}.{n}" in modules]
    return out


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def strong(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
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

    for v in sorted(graph):
        if v not in index:
            strong(v)
    return out


#: The one module that imports by name: code outside the tree, named by the user (a study's
#: ``[simulation] simulator = "package.module:function"``).
USER_CODE = {"hypate.scaling.workflow.vocabulary.external"}


def check_tree(root: Path) -> list[str]:
    """Every violation of the rules in the tree at ``root`` (empty when it complies)."""
    files = {}
    for folder in ROOTS:
        for path in sorted((root / folder).rglob("*.py")) if (root / folder).is_dir() else ():
            name = module_name(path, root)  # scaling/api/* is `hypate`, never hypate.scaling.api
            if name is not None:
                files.setdefault(name, path)
    modules = set(files)
    problems: list[str] = []
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for module, path in files.items():
        found, dynamic = imports_of(path, module)
        if module not in USER_CODE:
            problems += [f"{d}: import by string name" for d in dynamic]
        for imp in found:
            where = f"{path.relative_to(root)}:{imp.line}"
            lazy = (module, imp.target) in LAZY
            if imp.nested and not imp.target.split(".")[0] in OPTIONAL and not lazy:
                problems.append(f"{where}: import of {imp.target} inside a function or class")
            why = _layer_violation(module, imp.target)
            if why:
                problems.append(f"{where}: {module} imports {imp.target} ({why})")
            chooses = [n for n in imp.names if (imp.target, n) in RUNNERS]
            if chooses and (_is_under(module, "hypate.scaling.cli") or module == "hypate"
                            or module.startswith("hypate._")):
                problems.append(f"{where}: {module} imports {', '.join(chooses)} (only the "
                                "runner decides how a study runs)")
            private = [n for n in imp.names if n.startswith("_") and n != "__future__"]
            if private and _is_under(imp.target, "hypate"):
                problems.append(f"{where}: private name(s) {', '.join(private)} of {imp.target}")
            for loaded in _project_module(imp.target, imp.names, modules):
                parts = loaded.split(".")
                if any(p.startswith("_") for p in parts) and \
                        not _is_under(module, ".".join(parts[:-1])):
                    problems.append(f"{where}: private module {loaded} from outside its package")
                rooms = [_workflow_room(m) for m in (module, loaded)]
                if None not in rooms and \
                        WORKFLOW_ROOMS.index(rooms[0]) < WORKFLOW_ROOMS.index(rooms[1]):
                    problems.append(f"{where}: {module} imports {loaded} (a workflow room "
                                    "imports only the rooms before it)")
                if loaded != module:
                    graph[module].add(loaded)
    problems += [f"import cycle: {' -> '.join(c)}" for c in _cycles(graph)]
    return problems


def listed_packages(root: Path) -> set[str]:
    data = tomllib.loads((root / "pyproject.toml").read_text())
    return set(data["tool"]["setuptools"]["packages"])


def tree_packages(root: Path) -> set[str]:
    out = set()
    for folder in ROOTS:
        for init in (root / folder).rglob("__init__.py"):
            out.add(module_name(init, root))
    return out


# -- the contract on the real tree --------------------------------------------------------------
def test_the_tree_keeps_the_import_contract() -> None:
    problems = check_tree(REPO)
    assert not problems, "\n".join(problems)


def test_pyproject_lists_every_package_of_the_tree() -> None:
    assert listed_packages(REPO) == tree_packages(REPO)


# -- the contract fails when it should ------------------------------------------------------------
BROKEN = {
    "solvers/__init__.py": "",
    "solvers/numerics/__init__.py": "",
    "solvers/numerics/sparse.py": "from hypate.solvers.flow import GAMMA\n",
    "solvers/flow.py": "from hypate.scaling.engine.store import EvaluationStore\nGAMMA = 1.4\n",
    "scaling/__init__.py": "",
    "scaling/engine/__init__.py": "",
    "scaling/engine/store.py": ("from hypate.solvers.flow import GAMMA\n"
                                "from hypate.scaling.engine.pareto import _front\n"
                                "class EvaluationStore:\n    pass\n"),
    "scaling/engine/pareto.py": ("import importlib\n"
                                 "def _front():\n    from hypate.scaling.engine import store\n"
                                 "    return importlib.import_module('x')\n"),
    "scaling/engine/optimizer.py": "from hypate.scaling.engine import pareto, store\n",
    "scaling/workflow/__init__.py": "",
    "scaling/workflow/campaigns/run.py": "from hypate.scaling.report.html import write_report\n",
    "scaling/report/__init__.py": "",
    "scaling/report/html.py": "def write_report():\n    pass\n",
    "scaling/cli/__init__.py": "",
    "scaling/cli/run.py": "from hypate.scaling.workflow.campaigns.sweep import run_sweep\n",
    "scaling/workflow/campaigns/sweep.py": "def run_sweep():\n    pass\n",
    "scaling/workflow/vocabulary/study.py": "from hypate.scaling.workflow.analyses import whatif\n",
    "scaling/workflow/vocabulary/tunnels.py": "from hypate.scaling.workflow import campaigns\n",
    "scaling/workflow/campaigns/__init__.py": "",
    "scaling/workflow/analyses/whatif.py": "",
}


def test_the_contract_catches_each_kind_of_violation(tmp_path: Path) -> None:
    for rel, text in BROKEN.items():
        path = tmp_path / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    problems = "\n".join(check_tree(tmp_path))
    for expected in ("solvers.numerics imports nothing else of solvers/",
                     "the simulator imports nothing of scaling/",
                     "the engine knows only itself and solvers.numerics",
                     "the workflow does not import the report",
                     "study imports hypate.scaling.workflow.analyses.whatif (a workflow room",
                     "tunnels imports hypate.scaling.workflow.campaigns (a workflow room",
                     "private name(s) _front",
                     "inside a function or class",
                     "import by string name",
                     "imports run_sweep (only the runner decides how a study runs)",
                     "import cycle: hypate.scaling.engine.pareto -> hypate.scaling.engine.store"):
        assert expected in problems, problems
