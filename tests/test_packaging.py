"""The distribution installs every package directory, under unique import names, with its data files."""

import sys
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


def test_every_package_directory_is_listed_in_pyproject():
    cfg = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(cfg["packages"])
    rename = {v: k for k, v in cfg["package-dir"].items()}  # directory -> import name
    found = set()
    for init in ROOT.glob("**/__init__.py"):
        rel = init.parent.relative_to(ROOT)
        if rel.parts[0] in {"tests", "scripts", "build"} or any(p.startswith(".") for p in rel.parts):
            continue
        top = rename.get(rel.parts[0])
        if top is None:
            continue
        found.add(".".join((top, *rel.parts[1:])))
    assert found <= listed, f"not listed in pyproject packages: {sorted(found - listed)}"
    assert "sim" not in listed and "params" not in listed


def test_profiles_are_package_data():
    from ksbo_mav.profiles import available_profiles

    assert "sim-planar" in available_profiles()


def test_dev_extra_is_lean_and_ci_installs_the_interop_tools():
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    heavy = ("mavproxy",)  # MAVProxy pulls VTK and OpenCV: ~0.9 GB for one interoperability test
    assert not [r for r in extras["dev"] if r.lower().startswith(heavy)]
    assert [r for r in extras["interop"] if r.lower().startswith("mavproxy")]
    ci = (ROOT / ".ci" / "run").read_text()
    assert '-e ".[dev,interop]"' in ci and "\npytest\n" in ci
    readme = (ROOT / "README.md").read_text()
    assert 'pip install -e ".[dev]"' in readme and "\npytest\n" in readme
