"""Tuning campaigns on a MAVLink vehicle: snapshot, prior, safe BO over flown trials, journal/resume, accept/restore.

Campaign directory::

    campaign.json            settings (profile, method, budget, seed, prior, optimiser bounds, baseline)
    snapshot/vehicle.*       every parameter before the first write (.param, .params, .json with hash)
    prior.json               the kernel-selection prior (simulator episodes or local LHS), reused on resume
    journal.jsonl            one line per flown trial, appended and fsynced before the optimiser sees the value
    trials/trial_NNN.*       two-way tlog + JSON record of every trial
    result.json, report/     recommendation, before/after, plots; accepted.param/.params + diff.txt on accept

Resume (``--resume``) re-runs the optimiser with the same seed and answers its first calls from the journal
without flying (the optimiser is deterministic: BLAS is pinned to one thread); only new trials are flown. If a
replayed proposal ever differs from the journal, the journalled trials are folded into the prior instead, so no
recorded trial is lost or flown twice.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError, KsboError, UnsafeStartError, VehicleError
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.objective import MavlinkObjective, TrialStopped
from ksbo_mav.mav.snapshot import Snapshot, fsync_write, load_snapshot, write_param_files, write_snapshot
from ksbo_mav.mav.vehicle import Vehicle, trust_region
from ksbo_mav.objective import Flight


@dataclass
class CampaignConfig:
    dir: str
    profile: str | None = None
    method: str = "ksbo"
    budget: int = 30
    seed: int = 0
    prior: str = "auto"  # "sim", "local", "none", "auto" (sim for the built-in planar vehicle, else local)
    n_prior: int = 0  # 0 = default for the prior kind
    confirm: int = 1
    accept: bool = False
    end: str = "land"  # "land" or "hold"
    settle_s: float = 1.0
    sysid: int | None = None  # our own MAVLink ids (None: the link's defaults)
    compid: int | None = None
    safety: dict[str, float] = field(default_factory=dict)
    options: dict[str, Any] = field(default_factory=dict)


def optimizer_options(prior_kind: str, user: dict[str, Any]) -> dict[str, Any]:
    """Optimiser keyword options of a tuning campaign: the campaign's defaults, then the user's ``user``.

    Every mission score here is bounded above by 1 (P(a) <= 1; 3-D: 1 - RMS/limit), which is also the prior scale
    of P the benchmark campaign uses; the generic default (2 |P(a0)|) is far too tight. A simulator prior
    (``prior_kind == "sim"``) is a dense cloud around the baseline of the same task: its good points are a fair
    head start, so candidates may grow around any of them (``explore_from="all"``); a flown or no prior keeps the
    library default, growth from the baseline gains.
    """
    base: dict[str, Any] = {"signal_std": 1.0, "y_max": 1.0}
    if prior_kind == "sim":
        base["explore_from"] = "all"
    return {**base, **user}


class Journal:
    """Append-only JSON lines, each fsynced: a SIGKILL loses at most the trial being flown."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.entries: list[dict[str, Any]] = []
        if path.exists():
            for n, line in enumerate(path.read_text().splitlines(), 1):
                if not line.strip():
                    continue
                try:
                    self.entries.append(json.loads(line))
                except json.JSONDecodeError:
                    if n == len(path.read_text().splitlines()):  # a half-written last line: the trial was lost
                        break
                    raise InputError(f"{path}:{n}: corrupt journal line") from None

    def append(self, entry: dict[str, Any]) -> None:
        with open(self.path, "a") as fh:
            fh.write(json.dumps(entry) + "\n")
            fh.flush()
            os.fsync(fh.fileno())
        self.entries.append(entry)

    def of(self, kind: str) -> list[dict[str, Any]]:
        return [e for e in self.entries if e["kind"] == kind]


#: Non-gain failures worth another try: this computer fell behind the vehicle, or the telemetry was too sparse.
RETRY_OUTCOMES = ("client", "telemetry")
RETRIES = 2


class _Diverged(Exception):
    pass


def opt_bounds(profile: Any, x0: np.ndarray) -> np.ndarray:
    """Profile box intersected with the trust region around the baseline (see :func:`trust_region`)."""
    lo, hi = trust_region(profile, x0)
    return np.stack([lo, hi], axis=1)


def _entry(kind: str, f: Flight) -> dict[str, Any]:
    """Journal line of a flown trial. ``kind`` "failed": a trial that ended for a reason unrelated to the gains
    (pilot, link, telemetry): kept for the record, never given to the optimiser."""
    return {"kind": kind, "trial": f.meta["trial"], "x": [float(v) for v in f.gains], "P": float(f.P),
            "outcome": f.outcome, "record": f.meta["record"], "restored": f.meta["restored"],
            "rms": f.score.get("rms_lap2_m")}


class Campaign:
    def __init__(self, cfg: CampaignConfig, endpoint: Endpoint, *, resume: bool = False,
                 log: Callable[[str], None] = print, progress: Callable[[dict[str, Any]], None] | None = None,
                 connect_timeout: float = 15.0) -> None:
        self.cfg, self.endpoint, self.resume, self.log = cfg, endpoint, resume, log
        self.progress = progress or (lambda info: None)
        self.connect_timeout = connect_timeout
        self.dir = Path(cfg.dir)
        self.vehicle: Vehicle | None = None
        self.objective: MavlinkObjective | None = None
        self.baseline_trial: int | None = None

    # --- setup -------------------------------------------------------------------------------------------
    def _load_or_create(self, dry_run: bool) -> tuple[Snapshot | None, dict[str, float]]:
        v = self.vehicle
        assert v is not None
        cj = self.dir / "campaign.json"
        if self.resume:
            if not cj.exists():
                raise InputError(f"{self.dir} holds no campaign to resume (no campaign.json)")
            snap = load_snapshot(self.dir)
            check_identity(snap, v)
            base = snap.baseline()
            current = {n: v.params.read(n) for n in base}
            if any(not np.isclose(current[n], base[n], rtol=1e-6, atol=1e-7) for n in base):
                self.log("vehicle gains differ from the baseline (interrupted trial?): restoring the baseline")
                v.restore(base)
            else:
                self.log("baseline gains verified on the vehicle")
            return snap, base
        if (self.dir / "journal.jsonl").exists() or cj.exists():
            raise InputError(f"{self.dir} already holds a campaign; use --resume {self.dir} or another directory")
        base = {n: v.params.table[n].value for n in v.gains.vehicle}
        x0 = v.gains.from_vehicle(base)
        try:
            v.profile.check_gains(x0)
        except InputError as exc:
            raise InputError(f"the vehicle's current gains are outside the profile's search box ({exc}); "
                             "set safe gains inside the box first") from None
        if dry_run:
            return None, base
        snap = write_snapshot(self.dir / "snapshot" / "vehicle", v.identity.to_dict(), v.stack.name,
                              v.gains.generation, v.profile.name, list(v.gains.vehicle), v.params.table)
        self.log(f"snapshot written: {snap.path.with_suffix('')}.{{param,params,json}}")
        doc = {"config": asdict(self.cfg), "profile": v.profile.name, "baseline": base, "x0": x0.tolist(),
               "bounds": opt_bounds(v.profile, x0).tolist(), "identity": v.identity.to_dict(),
               "created_unix": time.time()}
        fsync_write(cj, json.dumps(doc, indent=1))
        return snap, base

    def plan(self, base: dict[str, float]) -> str:
        v = self.vehicle
        assert v is not None
        x0 = v.gains.from_vehicle(base)
        b = opt_bounds(v.profile, x0)
        rows = [f"  {g.name:<16} {n:<16} now {x:<10.5g} tune in [{lo:.5g}, {hi:.5g}]"
                for g, n, x, (lo, hi) in zip(v.profile.gains, v.gains.vehicle, x0, b)]
        return "\n".join([
            f"vehicle: sysid {v.identity.sysid}, {v.stack.name} {v.identity.firmware}"
            + (f", {v.gains.generation} parameter names" if v.gains.generation else ""),
            f"profile: {v.profile.name}; method {self.cfg.method}, {self.cfg.budget} trials "
            f"(+ prior '{self._prior_kind()}'), seed {self.cfg.seed}",
            f"mission: {v.mission.kind}, {v.mission.laps} laps of {v.mission.period:g} s at {v.mission.rate_hz} Hz",
            "gains (profile name, vehicle name, current value, optimiser range):", *rows,
            f"at the end: {'write the best gains (accept)' if self.cfg.accept else 'restore the baseline'}, "
            f"then {self.cfg.end}",
            f"logs: {self.dir}/trials, snapshot {self.dir}/snapshot"])

    def _prior_kind(self) -> str:
        k = self.cfg.prior
        if k == "auto":
            return "sim" if self.vehicle is not None and self.vehicle.profile.name == "sim-planar" else "local"
        return k

    def _prior(self, x0: np.ndarray, bounds: np.ndarray, journal: Journal) -> tuple[np.ndarray, np.ndarray] | None:
        path = self.dir / "prior.json"
        kind = self._prior_kind()
        if kind == "none":
            return None
        from ksbo_mav.select.design import lhs_design

        lo, hi = bounds[:, 0], bounds[:, 1]
        u0 = (x0 - lo) / (hi - lo)
        if kind == "sim":
            if path.exists():
                doc = json.loads(path.read_text())
                return np.array(doc["X"]), np.array(doc["y"])
            from ksbo_mav.objective import SimObjective

            n = self.cfg.n_prior or 36
            X = lo + lhs_design(n, len(x0), "local", center=u0, radius=0.25, seed=self.cfg.seed) * (hi - lo)
            y = SimObjective(self.vehicle.profile, seed=self.cfg.seed).batch(X)
            fsync_write(path, json.dumps({"kind": "sim", "X": X.tolist(), "y": y.tolist()}))
            self.log(f"prior: {n} simulator episodes around the baseline (in process, nothing flown)")
            return X, y
        if kind != "local":
            raise InputError(f"unknown prior {kind!r}; choose sim, local, none or auto")
        n = self.cfg.n_prior or 8
        X = lo + lhs_design(n, len(x0), "local", center=u0, radius=0.1, seed=self.cfg.seed) * (hi - lo)
        done = journal.of("prior")
        y = [e["P"] for e in done]
        for k in range(len(done), n):
            self.log(f"prior trial {k + 1}/{n} (local LHS around the baseline)")
            y.append(self._fly(X[k], "prior", journal).P)
        return X, np.array(y)

    # --- flying ----------------------------------------------------------------------------------------------
    def _fly(self, x: np.ndarray, kind: str, journal: Journal) -> Flight:
        """Fly one trial; a trial spoiled by this computer or the link rather than the gains (setpoints late,
        telemetry too sparse) is journalled as failed and flown again, up to :data:`RETRIES` times."""
        for attempt in range(RETRIES + 1):
            try:
                return self._fly_once(x, kind, journal)
            except TrialStopped as exc:
                if exc.flight.outcome not in RETRY_OUTCOMES or attempt == RETRIES:
                    raise
                self.log(f"trial {exc.flight.meta['trial']} not counted ({exc.flight.meta['message']}); "
                         "flying it again")
        raise AssertionError("unreachable")

    def _fly_once(self, x: np.ndarray, kind: str, journal: Journal) -> Flight:
        assert self.objective is not None
        try:
            f = self.objective.fly(x, label=kind)
        except (TrialStopped, KeyboardInterrupt) as exc:
            f = exc.flight if isinstance(exc, TrialStopped) else self.objective.last_flight
            fresh = f is not None and f.meta.get("trial") == self.objective.index - 1 and \
                not any(e["trial"] == f.meta["trial"] for e in journal.entries[-1:])
            if fresh:
                # A crash of a real vehicle is the gains' doing; anything else that stops a trial is not.
                journal.append(_entry(kind if f.outcome == "crash" else "failed", f))
            raise
        journal.append(_entry(kind, f))
        self.progress({"kind": kind, "flight": f, "journal": journal})
        return f

    def _baseline(self, x0: np.ndarray, journal: Journal) -> None:
        """Fly the baseline gains first (the optimiser's first evaluation, answered from the journal): every 3-D
        score is relative to this flight's tracking (:meth:`Mission.score`)."""
        assert self.objective is not None
        opt = journal.of("opt")
        if not opt:
            self.log("trial: baseline gains (the reference every score is measured against)")
            f = self._fly(x0, "opt", journal)
            opt = journal.of("opt")
            if f.P < 0:
                raise VehicleError(f"the baseline gains flew unsafe (P = {f.P:.3f} < 0, {f.outcome}: "
                                   f"{f.meta.get('message') or 'see the trial record'}); safe BO needs a safe start: "
                                   "fix the gains or the mission/safety settings first (baseline restored)")
        self.baseline_trial = int(opt[0]["trial"])
        if self.vehicle is not None and self.vehicle.mission.kind != "figure8-xz":
            self.objective.rms_ref = opt[0].get("rms")

    def run(self, dry_run: bool = False) -> dict[str, Any]:
        from threadpoolctl import threadpool_limits

        from ksbo_mav import optimize

        self.dir.mkdir(parents=True, exist_ok=True) if not dry_run else None
        self.vehicle = v = Vehicle.connect(self.endpoint, self.cfg.profile if not self.resume else
                                           _saved_profile(self.dir), sysid=self.cfg.sysid, compid=self.cfg.compid,
                                           timeout=self.connect_timeout, log=self.log)
        base: dict[str, float] | None = None
        try:
            snap, base = self._load_or_create(dry_run)
            if dry_run:
                return {"plan": self.plan(base)}
            x0 = v.gains.from_vehicle(base)
            bounds = opt_bounds(v.profile, x0)
            journal = Journal(self.dir / "journal.jsonl")
            v.setup_streams()
            self.objective = MavlinkObjective(v, base, self.dir / "trials", safety=self.cfg.safety,
                                              settle_s=self.cfg.settle_s, first_index=_next_index(self.dir),
                                              log=self.log)
            started = time.time()
            self._baseline(x0, journal)
            with threadpool_limits(1):
                prior = self._prior(x0, bounds, journal)
                result = self._optimize(optimize, x0, bounds, prior, journal)
            best = np.asarray(result.x, dtype=float)
            confirms = [e["P"] for e in journal.of("confirm")]
            for _ in range(len(confirms), self.cfg.confirm):
                confirms.append(self._fly(best, "confirm", journal).P)
            summary = self._finish(snap, base, best, result, journal, confirms, time.time() - started)
            return summary
        except (KeyboardInterrupt, KsboError) as exc:
            if base is not None and not isinstance(exc, InputError):
                self._safe_stop(base)
            self._end_flight(error=True)
            raise
        finally:
            v.close()

    def _optimize(self, optimize: Any, x0: np.ndarray, bounds: np.ndarray, prior: Any, journal: Journal) -> Any:
        done = journal.of("opt")
        calls = [0]

        def fun(x: np.ndarray) -> float:
            i = calls[0]
            calls[0] += 1
            if i < len(done):
                if not np.allclose(x, done[i]["x"], rtol=1e-9, atol=1e-12):
                    raise _Diverged()
                return float(done[i]["P"])
            return self._fly(x, "opt", journal).P

        options = optimizer_options(self._prior_kind(), self.cfg.options)
        kw = dict(budget=self.cfg.budget, method=self.cfg.method, seed=self.cfg.seed, p_min=0.0,
                  check_x0=True, **options)
        if self.resume and done:
            self.log(f"resume: replaying {len(done)} journalled trial(s) through the optimiser (nothing re-flown)")
        try:
            return optimize(fun, x0, bounds, prior=prior, **kw)
        except UnsafeStartError:
            P0 = journal.of("opt")[0]["P"]
            raise VehicleError(f"the baseline gains flew unsafe (P = {P0:.3f} < 0): safe BO needs a safe start; "
                               "fix the gains or the mission/safety settings first (baseline restored)") from None
        except _Diverged:
            self.log("resume: the optimiser's proposals differ from the journal; continuing with the journalled "
                     "trials as prior data")
            pX = np.array([e["x"] for e in done])
            py = np.array([e["P"] for e in done])
            if prior is not None:
                pX, py = np.vstack([prior[0], pX]), np.concatenate([prior[1], py])
            calls[0] = len(done)
            kw["budget"] = max(1, self.cfg.budget - len(done))
            return optimize(lambda x: self._fly(x, "opt", journal).P, x0, bounds, prior=(pX, py), **kw)

    def _safe_stop(self, base: dict[str, float] | None) -> None:
        """After Ctrl-C or an error between trials: make sure the baseline is on the vehicle (verified)."""
        v = self.vehicle
        if v is None or base is None or v.link.closed:
            return
        try:
            v.restore(base)
            self.log("stopped: baseline gains restored and verified")
        except (VehicleError, KeyboardInterrupt) as exc:
            self.log(f"stopped: baseline NOT verified ({exc}); run `ksbo-mav restore {self.dir}`")

    def _end_flight(self, error: bool) -> None:
        """Leave the vehicle landed and disarmed (``--end land``, and after any stop below the mission altitude or
        before a trial reached it), or holding where it is (``--end hold``): confirmed, or said why not."""
        v = self.vehicle
        if v is None or v.link.closed or not v.armed:
            return
        g = v.guided
        low = not g.height() >= 0.9 * float(v.mission.center_up)
        try:
            if self.cfg.end == "land" or (error and low):
                self.log("landing" + (" (stopped below the mission altitude)" if self.cfg.end != "land" else ""))
                g.land()
                self.log("landed and disarmed (confirmed by the heartbeat)")
            else:
                here = g.position()
                if here is not None:
                    g.hold_at(here)
                g.park() if v.stack.needs_stream else g.hold_at(None)
                self.log(f"holding at {g.height():.1f} m in {v.stack.mode_name(g.heartbeat.custom_mode)} (--end hold)")
        except (VehicleError, KeyboardInterrupt) as exc:
            self.log(f"could not land/hold the vehicle: {exc}; it is now under its own failsafes - take over")

    def _finish(self, snap: Snapshot | None, base: dict[str, float], best: np.ndarray, result: Any,
                journal: Journal, confirms: list[float], wall: float) -> dict[str, Any]:
        v = self.vehicle
        assert v is not None
        opt = journal.of("opt")
        base_P = opt[0]["P"] if opt else float("nan")
        best_values = v.gains.to_vehicle(best)
        if self.cfg.accept:
            v.restore(best_values)  # write + fresh read-back of every gain
            write_accepted(self.dir, base, best_values, v)
            self.log("accepted: best gains written and verified on the vehicle")
        else:
            v.restore(base)
            self.log("baseline gains restored and verified by a fresh read")
        on_vehicle = {n: v.params.table[n].value for n in base}
        self._end_flight(error=False)
        summary = {
            "baseline": {"x": v.gains.from_vehicle(base).tolist(), "values": base, "P": base_P,
                         "trial": self.baseline_trial, "rms_m": opt[0].get("rms") if opt else None},
            "best": {"x": best.tolist(), "values": best_values, "P_model": float(result.fun),
                     "P_confirm": float(np.mean(confirms)) if confirms else None, "P_confirm_all": confirms},
            "accepted": self.cfg.accept, "on_vehicle": on_vehicle,
            "n_trials": len(journal.entries), "n_unsafe": int(sum(e["P"] < 0 for e in opt)),
            "n_failed": len(journal.of("failed")),
            "n_aborted": int(sum(e["outcome"] != "ok" for e in journal.entries)),
            "method": self.cfg.method, "orders": list(result.orders) if result.orders else None,
            "wall_s": wall, "dir": str(self.dir),
        }
        fsync_write(self.dir / "result.json", json.dumps(summary, indent=1))
        try:
            from ksbo_mav.tune_report import write_report

            summary["plots"] = write_report(self.dir, v.profile)
        except Exception as exc:  # a plotting problem must never hide the tuning result
            self.log(f"report plots failed: {exc}")
        fsync_write(self.dir / "result.json", json.dumps(summary, indent=1))
        return summary


def _saved_profile(d: Path) -> str | None:
    try:
        return json.loads((d / "campaign.json").read_text())["profile"]
    except (OSError, KeyError, json.JSONDecodeError):
        raise InputError(f"{d} holds no readable campaign.json to resume") from None


def _next_index(d: Path) -> int:
    trials = sorted((d / "trials").glob("trial_*.json")) + sorted((d / "trials").glob("trial_*.tlog"))
    nums = [int(p.stem.split("_")[1]) for p in trials if p.stem.split("_")[1].isdigit()]
    return max(nums) + 1 if nums else 0


def check_identity(snap: Snapshot, v: Vehicle) -> None:
    """Refuse to write a snapshot's values to a different vehicle."""
    ident = v.identity.to_dict()
    for key in ("sysid", "autopilot", "vendor_id", "product_id"):
        if key in snap.identity and snap.identity[key] != ident[key]:
            raise InputError(f"snapshot {snap.path} is from another vehicle ({key} {snap.identity[key]} vs "
                             f"{ident[key]})")
    missing = [n for n in snap.gain_names if n not in v.params.table]
    if missing:
        raise InputError(f"vehicle lacks parameter(s) of the snapshot: {', '.join(missing)}")


def write_accepted(d: Path, base: dict[str, float], best: dict[str, float], v: Vehicle) -> None:
    types = {n: v.params.table[n].ptype for n in best}
    write_param_files(d / "accepted", best, types, v.identity.sysid, v.identity.compid)
    lines = [f"{n:<16} {base[n]:>14.7g} -> {best[n]:<14.7g} ({(best[n] - base[n]):+.4g})" for n in best]
    fsync_write(d / "diff.txt", "\n".join(["# parameter     baseline -> accepted", *lines]) + "\n")


def restore_snapshot(path: str | Path, endpoint: Endpoint, log: Callable[[str], None] = print,
                     timeout: float = 15.0, sysid: int | None = None, compid: int | None = None) -> dict[str, float]:
    """Write a snapshot's tuned gains back and verify them by a fresh read (works after any crash)."""
    snap = load_snapshot(path)
    v = Vehicle.connect(endpoint, snap.profile, sysid=sysid, compid=compid, timeout=timeout, log=log)
    try:
        check_identity(snap, v)
        base = snap.baseline()
        v.restore(base)
        others = [n for n, (val, _) in snap.params.items()
                  if n in v.params.table and n not in base and not n.startswith("SIM_")
                  and not np.isclose(v.params.table[n].value, val, rtol=1e-6, atol=1e-7)]
        if others:
            log(f"note: {len(others)} other parameter(s) differ from the snapshot and were left alone: "
                + ", ".join(others[:10]))
        return base
    finally:
        v.close()


def accept_campaign(d: str | Path, endpoint: Endpoint, log: Callable[[str], None] = print,
                    timeout: float = 15.0, sysid: int | None = None, compid: int | None = None) -> dict[str, float]:
    """Write a finished campaign's best gains (checked against the snapshot's trust region), verify, export."""
    d = Path(d)
    try:
        result = json.loads((d / "result.json").read_text())
    except (OSError, json.JSONDecodeError):
        raise InputError(f"{d} has no readable result.json (campaign not finished?)") from None
    snap = load_snapshot(d)
    v = Vehicle.connect(endpoint, snap.profile, sysid=sysid, compid=compid, timeout=timeout, log=log)
    try:
        check_identity(snap, v)
        base = snap.baseline()
        best = {str(n): float(x) for n, x in result["best"]["values"].items()}
        v.check_trial_gains(v.gains.from_vehicle(best), v.gains.from_vehicle(base))
        v.restore(best)
        write_accepted(d, base, best, v)
        return best
    finally:
        v.close()
