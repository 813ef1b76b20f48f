"""Dependencies point one way: ``ksbo_mav`` may import ``ksbo_sim``, never the reverse, and the MAVLink client and
the campaign load no simulator; scripts import no test helpers."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

IMPORT_ALL = """
import importlib, pkgutil, sys
import ksbo_sim
names = ["ksbo_sim"] + [m.name for m in pkgutil.walk_packages(ksbo_sim.__path__, "ksbo_sim.")
                        if not m.name.endswith("__main__")]
for name in names:
    importlib.import_module(name)
bad = sorted(m for m in sys.modules if m == "ksbo_mav" or m.startswith("ksbo_mav."))
print(len(names), " ".join(bad))
"""


def test_importing_ksbo_sim_does_not_import_ksbo_mav():
    # A fresh interpreter: pytest itself has imported ksbo_mav by now.
    out = subprocess.run([sys.executable, "-c", IMPORT_ALL], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    n, _, bad = out.stdout.strip().partition(" ")
    assert int(n) > 10  # every module of the package was imported, not just its __init__
    assert bad == "", f"ksbo_sim pulled in {bad}"


CLIENT_WITHOUT_SIMULATOR = """
import importlib, pkgutil, sys
import ksbo_mav.campaign
names = ["ksbo_mav.mav.vehicle", "ksbo_mav.campaign"] + [
    m.name for m in pkgutil.walk_packages(ksbo_mav.campaign.__path__, "ksbo_mav.campaign.")]
simulator = lambda m: m.split(".")[0] in ("jsbsim", "ksbo_sim")
for name in names:
    importlib.import_module(name)
    loaded = sorted(m for m in sys.modules if simulator(m))
    if loaded:
        print(len(names), name, "loaded", " ".join(loaded))
        break
else:
    print(len(names))
"""


def test_the_mavlink_client_and_the_campaign_load_no_simulator():
    # A fresh interpreter, each module in turn: the first one after which JSBSim or ksbo_sim is loaded is named.
    out = subprocess.run([sys.executable, "-c", CLIENT_WITHOUT_SIMULATOR], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    n, _, offender = out.stdout.strip().partition(" ")
    assert int(n) > 10  # every campaign module was imported, not just the package
    assert offender == "", f"importing {offender}"


def _imported_modules(path: Path) -> set[str]:
    mods = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            mods.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            mods.add(node.module)
    return mods


def test_no_simulator_source_names_ksbo_mav_in_an_import():
    # Also catches imports inside functions that the import test above would not execute.
    offenders = [f"{p.relative_to(ROOT)}: {m}" for p in sorted((ROOT / "sim").rglob("*.py"))
                 for m in _imported_modules(p) if m.split(".")[0] == "ksbo_mav"]
    assert offenders == []


def test_scripts_do_not_put_tests_on_sys_path():
    for p in sorted((ROOT / "scripts").glob("*.py")):
        text = p.read_text()
        assert '/ "tests"' not in text and "'tests'" not in text, f"{p.name} reaches into tests/"
        mods = _imported_modules(p)
        assert not mods & {"sim_mavlink_helpers", "mav_tune_helpers", "conftest"}, p.name
