"""The package's layout: no import cycle (between modules, and between rooms), each room
imports only the rooms below it, no module over 500 lines, and ``import multilatin`` stays
cheap (the public names load lazily)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

import multilatin

PACKAGE = Path(multilatin.__file__).parent

#: rooms from the bottom up; a room may import only itself and the rooms before it
ROOMS = ["errors", "limits", "kept", "parameters", "fem", "decomposition", "io", "latin",
         "reference", "model", "study", "cli"]
#: rooms at the same height that must not see each other (the references check the solver)
APART = {("latin", "reference"), ("reference", "latin")}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _runtime_imports(path: Path) -> set[str]:
    """Modules of the package that ``path`` imports when it runs (``if TYPE_CHECKING:``
    blocks left out; imports inside functions included)."""
    module = _module_name(path)
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    tree = ast.parse(path.read_text(), str(path))
    skipped: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skipped.update(id(n) for stmt in node.body for n in ast.walk(stmt))
    found: set[str] = set()
    for node in ast.walk(tree):
        if id(node) in skipped:
            continue
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.startswith("multilatin"))
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            elif node.module and node.module.startswith("multilatin"):
                target = node.module
            else:
                continue
            found.add(target)
            for alias in node.names:  # ``from . import kernels`` names a module
                if (PACKAGE.parent / (target + "." + alias.name).replace(".", "/")).with_suffix(
                        ".py").exists() or (PACKAGE.parent / (target + "." + alias.name)
                                            .replace(".", "/") / "__init__.py").exists():
                    found.add(target + "." + alias.name)
    # a module's own packages are initialised before it: importing from them is no edge
    return {t for t in found if t != module and not module.startswith(t + ".")}


def _graph() -> dict[str, set[str]]:
    return {_module_name(p): _runtime_imports(p) for p in PACKAGE.rglob("*.py")}


def _room(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "multilatin"


def _find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if nxt not in graph:
                continue
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (cycle := visit(nxt)):
                return cycle
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (cycle := visit(node)):
            return cycle
    return None


def test_no_import_cycle_between_modules() -> None:
    cycle = _find_cycle(_graph())
    assert cycle is None, "import cycle: " + " -> ".join(cycle or [])


def test_no_import_cycle_between_rooms() -> None:
    rooms: dict[str, set[str]] = {}
    for module, imported in _graph().items():
        if _room(module) != "multilatin":
            rooms.setdefault(_room(module), set()).update(
                _room(t) for t in imported if _room(t) not in (_room(module), "multilatin"))
    cycle = _find_cycle(rooms)
    assert cycle is None, "rooms import each other: " + " -> ".join(cycle or [])


def test_each_room_imports_only_the_rooms_below_it() -> None:
    wrong = []
    for module, imported in _graph().items():
        room = _room(module)
        if room == "multilatin":  # the top level names everything, lazily
            continue
        assert room in ROOMS, f"{module}: room {room!r} is not in the layout's list"
        for target in imported:
            other = _room(target)
            if other == "multilatin" or other == room:
                continue
            if ROOMS.index(other) > ROOMS.index(room) or (room, other) in APART:
                wrong.append(f"{module} imports {target}")
    assert not wrong, "imports against the layout:\n" + "\n".join(sorted(wrong))


def test_the_checks_themselves_find_cycles_and_imports() -> None:
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None
    # the walker: relative imports, ``from . import module``, a TYPE_CHECKING block
    latin = PACKAGE / "latin" / "operators.py"
    assert "multilatin.latin.local_stage" in _runtime_imports(latin)
    assert "multilatin.latin.options" not in _runtime_imports(latin)  # types only
    assert "multilatin.latin.kernels" in _runtime_imports(PACKAGE / "latin" / "engine.py")


def test_no_module_over_500_lines() -> None:
    long = {str(p.relative_to(PACKAGE)): n for p in PACKAGE.rglob("*.py")
            if (n := len(p.read_text().splitlines())) > 500}
    assert not long, f"modules over 500 lines: {long}"


def test_import_multilatin_loads_no_solver_and_no_heavy_library() -> None:
    code = ("import sys, multilatin; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in "
            "('numba', 'xarray', 'dask', 'matplotlib', 'scipy', 'torch') "
            "or m.startswith('multilatin.')))")
    out = _python(code)
    assert out == "[]", out
    assert multilatin.LatinOptions().kappa > 0  # the lazy names resolve


def test_the_public_names_resolve_and_are_listed() -> None:
    for name in multilatin.__all__:
        assert getattr(multilatin, name) is not None
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        multilatin.nothing  # noqa: B018


def test_the_command_line_loads_no_solver_and_no_heavy_library_before_a_command_needs_it(
) -> None:
    code = ("import sys, multilatin.cli; "
            "print(sorted({m.split('.')[0] for m in sys.modules} & "
            "{'numba', 'xarray', 'dask', 'distributed', 'matplotlib', 'meshio', 'tqdm', "
            "'torch'}), "
            "sorted(m for m in sys.modules if m.startswith(('multilatin.latin.solver', "
            "'multilatin.latin.kernels', 'multilatin.reference', 'multilatin.study'))))")
    out = _python(code)
    assert out == "[] []", out


def test_the_numpy_backend_never_loads_pytorch() -> None:
    code = ("import sys, multilatin as ml; ml.load_model('b0').solve(); "
            "print('torch' in sys.modules, 'multilatin.latin.torch_engine' in sys.modules)")
    out = _python(code)
    assert out == "False False", out


def _python(code: str) -> str:
    """What ``code`` prints in a fresh interpreter (nothing imported yet), stripped."""
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip()
