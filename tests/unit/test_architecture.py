"""The layers of ARCHITECTURE.md, enforced: a package imports only from its own layer's packages
below it, never from a layer above (function-level imports included); modules import each other
without cycles, and never a private ``_name`` of another module; an import inside a function says
which heavy dependency it defers (and `pipette --help` imports none of them); every third-party
package imported is declared in pyproject.toml; and modules keep to size."""

from __future__ import annotations

import ast
import json
import re
import subprocess
import sys
import tomllib
from importlib.metadata import packages_distributions
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2] / "pipette_cli"

# lowest first; a package may import from any package in an earlier layer (and from itself)
LAYERS: list[set[str]] = [
    {"kernels"},  # the package's __init__ imports it before anything loads numpy
    {"__init__", "errors", "progress"},
    {"plugins"},
    {"resources"},
    {"templating", "specs"},
    {"assets", "llm"},
    {"registry", "evaluators"},
    {"sim"},
    {"skills"},
    {"demos"},
    {"augment", "lerobot", "serving"},
    {"evaluation"},
    {"language"},
    {"taskgen"},
    {"authoring", "demo"},
    {"agent"},
    {"cli", "envs"},
]
LAYER = {package: depth for depth, packages in enumerate(LAYERS) for package in packages}
MAX_LINES = 500


def _package(path: Path) -> str:
    return path.relative_to(ROOT).parts[0].removesuffix(".py")


def _imports(path: Path) -> list[tuple[int, str]]:
    """(line, imported pipette_cli package) for every import in the module, at any depth."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        names = []
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        for name in names:
            parts = name.split(".")
            if parts[0] == "pipette_cli":
                out.append((node.lineno, parts[1] if len(parts) > 1 else "__init__"))
    return out


MODULES = sorted(ROOT.rglob("*.py"))


def test_every_package_has_a_layer() -> None:
    packages = {_package(p) for p in MODULES}
    assert packages - set(LAYER) == set(), "add new packages to ARCHITECTURE.md and LAYERS"


def test_imports_point_down_the_layers() -> None:
    wrong = []
    for path in MODULES:
        own = _package(path)
        for line, target in _imports(path):
            if target != own and target in LAYER and LAYER[target] >= LAYER[own]:
                wrong.append(
                    f"{path.relative_to(ROOT.parent)}:{line}: {own} (layer {LAYER[own]}) imports "
                    f"{target} (layer {LAYER[target]})"
                )
    assert wrong == []


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(ROOT)))
def test_modules_stay_small(path: Path) -> None:
    lines = len(path.read_text().splitlines())
    assert lines <= MAX_LINES, f"{path.relative_to(ROOT.parent)} has {lines} lines; split it by concept"


SKILLS_MAX_LINES = 350
"""The skills package is what every expert runs on: its modules stay smaller still (issue 35)."""


@pytest.mark.parametrize("path", sorted((ROOT / "skills").rglob("*.py")), ids=lambda p: str(p.relative_to(ROOT)))
def test_skill_modules_stay_smaller(path: Path) -> None:
    lines = len(path.read_text().splitlines())
    assert lines <= SKILLS_MAX_LINES, f"{path.relative_to(ROOT.parent)} has {lines} lines; split it by concept"


SKILL_LIBRARY = ROOT / "skills" / "library"


def _skill_imports(path: Path) -> list[tuple[int, str]]:
    """(line, what) for every import in ``path`` of a skill module or the skill package
    (``pipette_cli.skills.library``)."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        else:
            continue
        out += [(node.lineno, n) for n in names if (n + ".").startswith("pipette_cli.skills.library.")]
    return out


def test_skills_do_not_import_skills() -> None:
    """A skill module imports the shared motions and geometry (``skills/motions.py``, ``handling.py``,
    ``targets.py``, ...), never another skill: what two skills share moves out of both."""
    wrong = [
        f"{path.relative_to(ROOT.parent)}:{line}: {name}"
        for path in sorted(SKILL_LIBRARY.glob("*.py"))
        if path.name != "__init__.py"
        for line, name in _skill_imports(path)
    ]
    assert wrong == [], "move what the skills share into a module of pipette_cli/skills/ both import"


def test_the_skill_import_check_sees_one(tmp_path: Path) -> None:
    module = tmp_path / "m.py"
    module.write_text(
        "from pipette_cli.skills.library.place import put_down\n"
        "from pipette_cli.skills.library import pick\n"
        "import pipette_cli.skills.library.hinge\n"
        "from pipette_cli.skills.motions import back_off\n"
    )
    assert [line for line, _ in _skill_imports(module)] == [1, 2, 3]


LANGUAGE = ROOT / "language"
FRONT_ENDS = [ROOT / "agent", ROOT / "authoring"]
SHARED_LANGUAGE = {
    "phrases": {"phrase_pattern", "find_phrase", "words_of", "singular", "match", "first_match", "Token"},
    "clauses": {"split_clauses", "pieces", "Separators"},
    "mentions": {"find_mentions", "name_at", "names_in", "word_tokens"},
    "lexicon": {"registry_values", "suite_words", "robot_mentions", "short_name", "camel_words", "stem"},
    "assets": {"load_vocabulary", "Vocabulary", "VocabularySpec"},
}
"""What the two language front-ends share, by module of pipette_cli/language/."""


def _definitions(path: Path) -> list[tuple[int, str]]:
    """(line, name) of every module-level function and class."""
    return [
        (node.lineno, node.name)
        for node in ast.parse(path.read_text(), str(path)).body
        if isinstance(node, ast.FunctionDef | ast.ClassDef)
    ]


def _front_end_modules() -> list[Path]:
    return sorted(p for root in FRONT_ENDS for p in root.rglob("*.py"))


def test_the_language_front_ends_share_one_home_for_each_part() -> None:
    """One lexicon, one clause splitter, one mention resolver for `pipette agent` and `pipette
    new-task` (issue 33): each shared part is defined in pipette_cli/language/ and nowhere in
    agent/ or authoring/, where a grammar keeps only its own rules on top."""
    for module, names in SHARED_LANGUAGE.items():
        defined = {name for _, name in _definitions(LANGUAGE / f"{module}.py")}
        assert names <= defined, f"language/{module}.py lacks {sorted(names - defined)}"
    shared = {name for names in SHARED_LANGUAGE.values() for name in names} - {"split_clauses", "load_vocabulary"}
    again = [
        f"{path.relative_to(ROOT.parent)}:{line}: {name}"
        for path in _front_end_modules()
        for line, name in _definitions(path)
        if name in shared
    ]
    assert again == [], "use the part in pipette_cli/language/ instead of a second one"


def test_taskgen_reads_no_words() -> None:
    """`taskgen/` turns a typed plan into a task: of the language package it reads only the asset
    facts (`language/assets.py`: kinds, members, size tags), never the splitter, phrases or mentions."""
    wrong = []
    for path in sorted((ROOT / "taskgen").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                reads_words = (
                    node.module.startswith("pipette_cli.language") and node.module != "pipette_cli.language.assets"
                )
                if reads_words or node.module.startswith("pipette_cli.authoring"):
                    wrong.append(f"{path.relative_to(ROOT.parent)}:{node.lineno}: {node.module}")
    assert wrong == [], "taskgen builds from the plan; reading words belongs to the task grammar (authoring/)"


def _splits_without_the_splitter(path: Path) -> list[tuple[int, str]]:
    """(line, name) of each function named ``split*`` that does not call language's ``split_clauses``."""
    tree = ast.parse(path.read_text(), str(path))
    imported = {
        alias.asname or alias.name
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom) and node.module in ("pipette_cli.language.clauses", "pipette_cli.language")
        for alias in node.names
    }
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef) and node.name.startswith("split"):
            called = {
                (c.func.value.id if isinstance(c.func, ast.Attribute) and isinstance(c.func.value, ast.Name) else "")
                + ("." if isinstance(c.func, ast.Attribute) else "")
                + (c.func.attr if isinstance(c.func, ast.Attribute) else getattr(c.func, "id", ""))
                for c in ast.walk(node)
                if isinstance(c, ast.Call)
            }
            uses = ("split_clauses" in called and "split_clauses" in imported) or any(
                call.endswith(".split_clauses") and call.split(".")[0] in imported for call in called
            )
            if not uses:
                out.append((node.lineno, node.name))
    return out


def test_front_end_splitters_call_the_one_clause_splitter() -> None:
    wrong = [
        f"{path.relative_to(ROOT.parent)}:{line}: {name}"
        for path in _front_end_modules()
        for line, name in _splits_without_the_splitter(path)
    ]
    assert wrong == [], "split clauses with pipette_cli.language.clauses.split_clauses (the grammar decides `starts`)"


def test_the_splitter_check_sees_a_second_splitter(tmp_path: Path) -> None:
    module = tmp_path / "m.py"
    module.write_text(
        "import re\nfrom pipette_cli.language.clauses import split_clauses\n"
        "def split_steps(text):\n    return re.split(r',', text)\n"
        "def split_ok(text, s):\n    return split_clauses(text, s)\n"
    )
    assert _splits_without_the_splitter(module) == [(3, "split_steps")]


def test_the_layer_check_sees_a_wrong_import(tmp_path: Path) -> None:
    module = tmp_path / "m.py"
    module.write_text("def f():\n    from pipette_cli.cli.main import app\n")
    assert _imports(module) == [(2, "cli")]


def _private_imports(path: Path) -> list[tuple[int, str]]:
    """(line, ``module.name``) for every ``_name`` the module imports from another module of the package."""
    return [
        (node.lineno, f"{node.module}.{alias.name}")
        for node in ast.walk(ast.parse(path.read_text(), str(path)))
        if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").startswith("pipette_cli")
        for alias in node.names
        if alias.name.startswith("_") and not alias.name.startswith("__")
    ]


def test_no_module_imports_a_private_name_of_another() -> None:
    private = [
        f"{path.relative_to(ROOT.parent)}:{line}: {name}" for path in MODULES for line, name in _private_imports(path)
    ]
    assert private == [], "make the name public in the module that owns it (or move it where both can import it)"


def test_the_private_import_check_sees_one(tmp_path: Path) -> None:
    module = tmp_path / "m.py"
    module.write_text("from pipette_cli.skills.grasp import Grasp, __all__, _first_reachable\n")
    assert _private_imports(module) == [(1, "pipette_cli.skills.grasp._first_reachable")]


def _function_imports(path: Path) -> list[tuple[int, bool]]:
    """(line, has a ``deferred:`` comment) for every import inside a function of the module. The
    comment is on the import's lines or in the run of comment and import lines right above it (one
    comment may head a group of imports)."""
    lines = path.read_text().splitlines()
    tree = ast.parse("\n".join(lines), str(path))
    inner = [
        node
        for fn in ast.walk(tree)
        if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef))
        for node in ast.walk(fn)
        if isinstance(node, (ast.Import, ast.ImportFrom))
    ]
    import_lines = {i for node in inner for i in range(node.lineno, (node.end_lineno or node.lineno) + 1)}
    out = {}
    for node in inner:
        said = [lines[i - 1] for i in range(node.lineno, (node.end_lineno or node.lineno) + 1)]
        above = node.lineno - 1
        while above >= 1 and (above in import_lines or lines[above - 1].lstrip().startswith("#")):
            said.append(lines[above - 1])
            above -= 1
        out[node.lineno] = any("# deferred: " in line for line in said)
    return sorted(out.items())


def test_function_level_imports_say_what_they_defer() -> None:
    bare = [
        f"{path.relative_to(ROOT.parent)}:{line}"
        for path in MODULES
        for line, commented in _function_imports(path)
        if not commented
    ]
    assert bare == [], (
        "import at the top of the module; inside a function only to keep a heavy dependency out of "
        "`pipette --help`, with a comment `# deferred: <what> (<cost>)`"
    )


def test_the_deferral_check_sees_a_bare_import(tmp_path: Path) -> None:
    module = tmp_path / "m.py"
    module.write_text(
        "def f():\n"
        "    from pipette_cli.registry import load_registry\n"
        "\n"
        "def g():\n"
        "    # deferred: torch (~1 s)\n"
        "    import json\n"
        "    import torch\n"
        "    import numpy  # deferred: numpy\n"
    )
    assert _function_imports(module) == [(2, False), (6, True), (7, True), (8, True)]


def _module_name(path: Path) -> str:
    return ".".join(path.relative_to(ROOT.parent).with_suffix("").parts).removesuffix(".__init__")


def _runtime_graph(paths: list[Path]) -> dict[str, set[str]]:
    """Module -> the pipette_cli modules it imports when it is imported (module level, outside
    functions and ``if TYPE_CHECKING:``). ``from package import name`` counts the submodule
    ``package.name`` where there is one."""
    known = {_module_name(p) for p in paths}
    graph: dict[str, set[str]] = {}
    for path in paths:
        edges: set[str] = set()
        stack: list[ast.AST] = list(ast.parse(path.read_text(), str(path)).body)
        while stack:
            node = stack.pop()
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                continue
            if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
                stack.extend(node.orelse)
                continue
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                for alias in node.names:
                    sub = f"{node.module}.{alias.name}"
                    edges.add(sub if sub in known else node.module)
            elif isinstance(node, ast.Import):
                edges.update(alias.name for alias in node.names)
            stack.extend(ast.iter_child_nodes(node))
        name = _module_name(path)
        graph[name] = {e for e in edges if e in known and e != name}
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """One cycle (as a path that returns to its start) per strongly connected group of modules."""
    order, low, on_stack, stack, found = {}, {}, set(), [], []

    def visit(v: str) -> None:
        order[v] = low[v] = len(order)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in order:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], order[w])
        if low[v] == order[v]:
            group = []
            while not group or group[-1] != v:
                group.append(stack.pop())
                on_stack.discard(group[-1])
            if len(group) > 1:
                found.append(_shortest_cycle(graph, v, set(group)))

    for v in sorted(graph):
        if v not in order:
            visit(v)
    return found


def _shortest_cycle(graph: dict[str, set[str]], start: str, members: set[str]) -> list[str]:
    came_from: dict[str, str] = {}
    frontier = [start]
    while frontier:
        following = []
        for v in frontier:
            for w in sorted(graph[v] & members):
                if w == start:
                    path = [v]
                    while path[-1] != start:
                        path.append(came_from[path[-1]])
                    return [*reversed(path), start]
                if w not in came_from:
                    came_from[w] = v
                    following.append(w)
        frontier = following
    raise AssertionError(f"{start} is on no cycle")


def test_modules_import_each_other_without_cycles() -> None:
    cycles = [" -> ".join(c) for c in _cycles(_runtime_graph(MODULES))]
    assert cycles == [], "move the shared part into a module both can import"


def test_the_cycle_check_sees_a_cycle(tmp_path: Path) -> None:
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": set()}
    assert _cycles(graph) == [["a", "b", "c", "a"]]
    graph = {"a": {"b"}, "b": {"c", "d"}, "c": {"b"}, "d": {"a"}}  # the walk through c is a dead end
    assert _cycles(graph) == [["a", "b", "d", "a"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


# Heavy packages no command's --help needs: what the deferred imports above keep out of it.
DEFERRED = ["torch", "lerobot", "datasets", "zmq", "httpx", "scipy", "mink", "ray", "PIL", "glfw", "pxr.Usd"]


def test_pipette_help_imports_no_heavy_dependency() -> None:
    code = (
        "import json, sys; import pipette_cli.cli.main; "
        f"print(json.dumps([m for m in {DEFERRED!r} if m in sys.modules]))"
    )
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert json.loads(loaded) == []


def _distribution(name: str) -> str:
    """A distribution's name as pip compares them (PEP 503): ``ruamel.yaml`` and ``Ruamel_YAML`` are one."""
    return re.sub(r"[-_.]+", "-", name).lower()


def test_every_imported_package_is_declared() -> None:
    project = tomllib.loads((ROOT.parent / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    requirements = project["dependencies"] + [r for extra in project["optional-dependencies"].values() for r in extra]
    declared = {_distribution(re.split(r"[\s\[<>=!~;]", r, maxsplit=1)[0]) for r in requirements}
    providers = packages_distributions()
    undeclared = []
    for path in MODULES:
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                tops = [node.module.split(".")[0]]
            elif isinstance(node, ast.Import):
                tops = [alias.name.split(".")[0] for alias in node.names]
            else:
                continue
            for top in tops:
                if top == "pipette_cli" or top in sys.stdlib_module_names:
                    continue
                dists = {_distribution(d) for d in providers.get(top, [top])}
                if not dists & declared:
                    undeclared.append(
                        f"{path.relative_to(ROOT.parent)}:{node.lineno}: {top} ({', '.join(sorted(dists))})"
                    )
    assert not undeclared, "declare in pyproject.toml what these import:\n" + "\n".join(undeclared)
