"""The package layout's contract (core/__init__.py, service/__init__.py, docs/layout.md): `core` is grouped by
the paper's parts, its packages stack without an arrow back up, nothing in the project imports in a circle,
and `core` imports none of the other dualsys packages; `service` is grouped by the process that runs each
part, its database layer imports no other layer, and a job's own process never imports the database.
Every import counts, the ones inside functions too."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("core", "dualsys_cli", "registry", "service", "sim2real", "bench")

CORE_FLOORS = {
    "core.task_levels": 0,
    "core.config": 1,
    "core.envs": 2,
    "core.modelfree": 3,
    "core.dual": 4,
    "core.runs": 5,
    "core.experiments": 6,
    "core.deploy": 6,
}
"""The floor of each part of ``core``: a module may import its own part and the floors below."""


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> dict[str, Path]:
    return {
        _module_name(path): path for package in PACKAGES for path in sorted((ROOT / package).rglob("*.py"))
    }


def _imports(path: Path, known: set[str]) -> set[str]:
    """The project modules `path` imports (``from a.b import c`` counts as a.b.c when that is a module)."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for alias in node.names:
                if f"{node.module}.{alias.name}" in known:
                    found.add(f"{node.module}.{alias.name}")
            if node.module in known:
                found.add(node.module)
        elif isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names if alias.name in known)
    return found


def _floor(module: str) -> tuple[str, int]:
    for part, floor in CORE_FLOORS.items():
        if module == part or module.startswith(part + "."):
            return part, floor
    raise AssertionError(f"{module} is in no part of core: add it to a package (core/__init__.py)")


def test_core_has_at_most_five_modules_beside_its_packages() -> None:
    loose = sorted(p.name for p in (ROOT / "core").glob("*.py") if p.name != "__init__.py")
    assert len(loose) <= 5, loose


def test_core_packages_stack_without_an_arrow_back_up() -> None:
    modules = _modules()
    upward = []
    for module, path in modules.items():
        if not module.startswith("core.") or module == "core":
            continue
        part, floor = _floor(module)
        for target in _imports(path, set(modules)):
            assert target.split(".")[0] == "core", f"core imports another dualsys package: {module}→{target}"
            if target == "core":
                continue
            target_part, target_floor = _floor(target)
            if target_part != part and target_floor >= floor:
                upward.append(f"{module} → {target}")
    assert not upward, upward


def test_no_import_circle_anywhere() -> None:
    modules = _modules()
    graph = {module: _imports(path, set(modules)) for module, path in modules.items()}
    state: dict[str, int] = {}
    circles: list[list[str]] = []

    def visit(module: str, stack: list[str]) -> None:
        state[module] = 1
        stack.append(module)
        for target in graph[module]:
            if state.get(target) == 1:
                circles.append([*stack[stack.index(target) :], target])
            elif not state.get(target):
                visit(target, stack)
        stack.pop()
        state[module] = 2

    for module in graph:
        if not state.get(module):
            visit(module, [])
    assert not circles, circles[:3]


SERVICE_LAYERS = ("service.api", "service.ui", "service.execution", "service.database", "service.schemas")


def _service_imports(prefix: str) -> dict[str, set[str]]:
    """The service modules each module under `prefix` imports."""
    modules = _modules()
    return {
        module: {target for target in _imports(path, set(modules)) if target.split(".")[0] == "service"}
        for module, path in modules.items()
        if module == prefix or module.startswith(prefix + ".")
    }


def _in(module: str, *prefixes: str) -> bool:
    return any(module == prefix or module.startswith(prefix + ".") for prefix in prefixes)


def test_service_layers_import_only_downward() -> None:
    """What each lower part of the service may import of the service (the API, the dashboard and the
    launcher sit on top of them): the client nothing, the schemas only themselves, the database layer
    neither the API, the dashboard nor the execution layer, the execution layer not the API or dashboard."""
    allowed = {
        "service.client": (),
        "service.schemas": ("service.schemas",),
        "service.database": ("service.database", "service.schemas", "service.errors"),
        "service.execution": (
            "service.execution",
            "service.database",
            "service.schemas",
            "service.errors",
            "service.settings",
        ),
        # the dependencies the API's routes and the dashboard's pages share: below both
        "service.deps": ("service.database", "service.execution.supervisor", "service.settings"),
    }
    wrong = [
        f"{module} → {target}"
        for layer, below in allowed.items()
        for module, targets in _service_imports(layer).items()
        for target in targets
        if not _in(target, *below)
    ]
    assert not wrong, wrong


def test_the_api_and_the_dashboard_never_import_each_other() -> None:
    """`service.api` and `service.ui` sit side by side in the API process: what both need lives below them
    (`service.deps`), and only the launcher (`service.server.create_app`) puts them together."""
    wrong = [
        f"{module} → {target}"
        for layer, other in (("service.api", "service.ui"), ("service.ui", "service.api"))
        for module, targets in _service_imports(layer).items()
        for target in targets
        if _in(target, other)
    ]
    assert not wrong, wrong
    composers = sorted(
        module
        for module, targets in _service_imports("service").items()
        if any(_in(t, "service.api") for t in targets) and any(_in(t, "service.ui") for t in targets)
    )
    assert composers == ["service.server"], composers


def test_the_dashboard_reads_through_the_database_layer_and_the_registry_api() -> None:
    """`service.ui` writes no query of its own: jobs come from `service.database`'s stores, policies from the
    registry's Python API, so it imports neither SQLAlchemy nor the registry's tables."""
    wrong = []
    for module, path in _modules().items():
        if not _in(module, "service.ui"):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            names = (
                [node.module or ""]
                if isinstance(node, ast.ImportFrom)
                else [alias.name for alias in node.names]
                if isinstance(node, ast.Import)
                else []
            )
            wrong += [f"{module} → {name}" for name in names if _in(name, "sqlalchemy", "registry.models")]
    assert not wrong, wrong


def test_service_api_reaches_execution_only_through_the_supervisor_and_the_job_kinds() -> None:
    allowed = {"service.execution.supervisor", "service.execution.job_kinds"}
    wrong = [
        f"{module} → {target}"
        for layer in ("service.api", "service.ui")
        for module, targets in _service_imports(layer).items()
        for target in targets
        if _in(target, "service.execution") and target not in allowed
    ]
    assert not wrong, wrong


def test_a_jobs_own_process_never_imports_the_database() -> None:
    """What a job's process runs (`python -m service.execution.worker`, the Ray task) reaches neither
    `service.database` nor `registry.database`, directly or through what it imports."""
    modules = _modules()
    graph = {module: _imports(path, set(modules)) for module, path in modules.items()}
    for entry in ("service.execution.worker", "service.execution.executors.ray_task"):
        seen, stack = {entry}, [entry]
        while stack:
            for target in graph[stack.pop()]:
                if target not in seen:
                    seen.add(target)
                    stack.append(target)
        assert not [m for m in seen if _in(m, "service.database", "registry.database")], (entry, sorted(seen))


def test_every_service_module_is_in_a_layer() -> None:
    """Beside the layers, only the launcher, the client, the settings, the errors and the dependencies the
    API and the dashboard share stay at the top."""
    top = {
        "service",
        "service.server",
        "service.client",
        "service.settings",
        "service.errors",
        "service.deps",
    }
    loose = sorted(
        m for m in _modules() if _in(m, "service") and m not in top and not _in(m, *SERVICE_LAYERS)
    )
    assert not loose, loose
