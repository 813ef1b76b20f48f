"""The package's structure: no import cycle anywhere in ksbo_mav, the optimiser core (gp/, select/, opt/) reaches
no vehicle, simulator or campaign code, ksbo_sim never imports ksbo_mav, only the simulated objectives and the
commands that start a simulator import ksbo_sim, ksbo_task imports neither, nothing imports the benchmark runner
(ksbo_bench), and no module outgrows ~300 lines.

The graph is read from the source (every import statement, at module level or inside a function or a
TYPE_CHECKING block: a deferred import is still a dependency), so the test needs no import side effects."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = {"ksbo_mav": ROOT / "ksbo_mav", "ksbo_sim": ROOT / "sim", "ksbo_task": ROOT / "task",
            "ksbo_bench": ROOT / "bench"}
CORE = ("ksbo_mav.gp", "ksbo_mav.select", "ksbo_mav.opt")
FORBIDDEN_FOR_CORE = ("ksbo_sim", "ksbo_mav.mav", "ksbo_mav.campaign", "ksbo_mav.cli", "ksbo_mav.flightlog")
MAX_LINES = 320  # "about 300": a module past this is two concepts
#: The modules of ksbo_mav that may import ksbo_sim: the objectives flown in process on the simulators and the
#: commands that start a simulator process. The MAVLink client and the campaign load no simulator.
SIMULATOR_USERS = ("ksbo_mav.simulated", "ksbo_mav.cli.demo", "ksbo_mav.cli.sim", "ksbo_mav.cli.sim_pilot")


def _modules() -> dict[str, Path]:
    out = {}
    for pkg, folder in PACKAGES.items():
        for p in folder.rglob("*.py"):
            parts = (pkg, *p.relative_to(folder).with_suffix("").parts)
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            out[name] = p
    return out


MODULES = _modules()


def _imports(name: str, path: Path) -> set[str]:
    """Modules of ours that ``name`` imports (``from a.b import c`` counts a.b, and a.b.c when that is a module)."""
    pkg = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                head = pkg.split(".")[: len(pkg.split(".")) - node.level + 1]
                base = ".".join(head + ([base] if base else []))
            found.add(base)
            found.update(f"{base}.{a.name}" for a in node.names)
    return {m for m in found if m in MODULES and m != name}


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
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
            visit(v)
    return out


def _reach(start: str) -> dict[str, str]:
    """Every module reachable from ``start``: {module: the module that imported it on a shortest path}."""
    seen, frontier = {start: ""}, [start]
    while frontier:
        nxt = []
        for v in frontier:
            for w in sorted(GRAPH[v]):
                if w not in seen:
                    seen[w] = v
                    nxt.append(w)
        frontier = nxt
    return seen


def test_the_graph_is_read_and_sees_a_cycle_when_there_is_one() -> None:
    """The walker itself: it finds our modules and their imports, and it reports a cycle made up for the test."""
    assert "ksbo_mav.opt.methods.safe_bo" in GRAPH
    assert "ksbo_mav.opt.acquisition.certificate" in GRAPH["ksbo_mav.opt.methods.safe_bo"]
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_cycle_anywhere() -> None:
    assert _cycles(GRAPH) == []


@pytest.mark.parametrize("core", CORE)
def test_the_optimiser_core_imports_no_vehicle_simulator_or_campaign_code(core: str) -> None:
    bad = []
    for mod in (m for m in GRAPH if m == core or m.startswith(core + ".")):
        seen = _reach(mod)
        for hit in (m for m in seen if m.startswith(FORBIDDEN_FOR_CORE)):
            path, v = [hit], hit
            while seen[v]:
                v = seen[v]
                path.append(v)
            bad.append(" <- ".join(path))
    assert bad == []


def test_the_simulator_never_imports_the_tuner() -> None:
    assert [m for m in GRAPH if m.startswith("ksbo_sim") and any(w.startswith("ksbo_mav") for w in GRAPH[m])] == []


def _within(module: str, prefixes: tuple[str, ...]) -> bool:
    return any(module == p or module.startswith(p + ".") for p in prefixes)


def test_only_the_simulated_objectives_and_the_simulator_commands_import_the_simulator() -> None:
    bad = sorted(f"{m} imports {w}" for m, deps in GRAPH.items() if _within(m, ("ksbo_mav",))
                 and not _within(m, SIMULATOR_USERS) for w in deps if _within(w, ("ksbo_sim",)))
    assert bad == []


def test_the_task_package_imports_neither_the_tuner_nor_the_simulator() -> None:
    assert "ksbo_task.limit_checks" in GRAPH and "ksbo_task.lead_in" in GRAPH["ksbo_task.figure8_ne"]
    bad = sorted(f"{m} imports {w}" for m, deps in GRAPH.items() if _within(m, ("ksbo_task",))
                 for w in deps if _within(w, ("ksbo_mav", "ksbo_sim")))
    assert bad == []


def test_the_tuner_simulator_and_task_never_import_the_benchmark_runner() -> None:
    """ksbo_bench is a user of the tuner, like a researcher's script: nothing the tuner flies with depends on it."""
    assert "ksbo_bench.driver" in GRAPH and "ksbo_bench.kinds.plant" in GRAPH
    bad = sorted(f"{m} imports {w}" for m, deps in GRAPH.items() if not _within(m, ("ksbo_bench",))
                 for w in deps if _within(w, ("ksbo_bench",)))
    assert bad == []


def test_only_the_entry_points_import_the_safe_bo_loop() -> None:
    """The strategies receive what they need as arguments; only the loop's builders and drivers import it."""
    users = sorted(m for m, deps in GRAPH.items() if "ksbo_mav.opt.methods.safe_bo" in deps)
    assert users == ["ksbo_mav.opt.methods.build", "ksbo_mav.opt.methods.loop", "ksbo_mav.opt.methods.safe_methods"]


def test_no_module_outgrows_about_300_lines() -> None:
    long = {m: n for m, p in MODULES.items() if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert long == {}


def test_the_flying_code_never_imports_the_report() -> None:
    """The report reads a finished (or stopped) campaign back from disk: only the end of a campaign, the runner that
    orders it and the commands that show a campaign import it, never the trial loop or anything it flies with."""
    report = "ksbo_mav.campaign.report"
    users = {m for m, deps in GRAPH.items() if not (m == report or m.startswith(report + "."))
             and any(d == report or d.startswith(report + ".") for d in deps)}
    assert users and users <= {"ksbo_mav.campaign.ending", "ksbo_mav.campaign.runner", "ksbo_mav.cli.report",
                               "ksbo_mav.cli.tune"}, sorted(users)


def test_no_two_modules_share_a_name():
    """A reader who meets ``figure8`` or ``monitor`` in a traceback should not have to ask which one: module names
    are unique across ksbo_mav and ksbo_task (the commands under cli/ are named after the command they run)."""
    seen: dict[str, list[str]] = {}
    for name, path in MODULES.items():
        if name.startswith("ksbo_sim") or name.startswith("ksbo_mav.cli.") or path.stem in ("__init__", "__main__"):
            continue
        seen.setdefault(path.stem, []).append(name)
    assert {stem: names for stem, names in seen.items() if len(names) > 1} == {}
