"""The parameter cache keyed by a vehicle's parameter hash: what is saved loads back exactly; a damaged file, a
file of another count or with a repeated name is ignored (the set is then downloaded), never trusted."""

from __future__ import annotations

import json

from ksbo_mav.mav.params.cache import ParamHash, cache_dir, load, save

ROWS = [("MPC_XY_P", 0.95, 9), ("COM_RCL_EXCEPT", 4.0, 6), ("MPC_Z_P", 1.0000000474974513, 9)]


def test_a_saved_set_loads_back_exactly_under_its_hash_only(tmp_path) -> None:
    h = ParamHash(0xDEADBEEF, 3)
    path = save("px4", h, ROWS, tmp_path)
    assert path is not None and path.name == "px4-deadbeef-3.json"
    assert load("px4", h, tmp_path) == ROWS
    assert load("px4", ParamHash(0xDEADBEEE, 3), tmp_path) is None  # another hash: another set
    assert load("ardupilot", h, tmp_path) is None


def test_a_damaged_or_inconsistent_file_is_ignored(tmp_path) -> None:
    h = ParamHash(7, 3)
    path = save("px4", h, ROWS, tmp_path)
    path.write_text(path.read_text()[:-10])  # cut short
    assert load("px4", h, tmp_path) is None
    doc = {"names": ["A", "B"], "values": [1.0, 2.0], "types": [9, 9]}
    path.write_text(json.dumps(doc))  # two parameters where the vehicle said three
    assert load("px4", h, tmp_path) is None
    path.write_text(json.dumps({"names": ["A", "A", "B"], "values": [1.0, 1.0, 2.0], "types": [9, 9, 9]}))
    assert load("px4", h, tmp_path) is None
    path.write_text(json.dumps({"names": ["A", "B", "C"], "values": [1.0, "x", 2.0], "types": [9, 9, 9]}))
    assert load("px4", h, tmp_path) is None


def test_an_unwritable_cache_does_not_stop_anything(tmp_path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert save("px4", ParamHash(1, 3), ROWS, blocker / "sub") is None


def test_the_cache_folder_follows_the_environment(monkeypatch, tmp_path) -> None:
    monkeypatch.setenv("KSBO_MAV_CACHE_DIR", str(tmp_path / "c"))
    assert cache_dir() == tmp_path / "c"
    monkeypatch.delenv("KSBO_MAV_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "x"))
    assert cache_dir() == tmp_path / "x" / "ksbo-mav" / "params"
