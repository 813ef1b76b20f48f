"""ksbo-bench: run the benchmarks declared in benchmarks/sweeps/*.toml and make their pages.

    ksbo-bench list                                        # the sweeps, their kinds and cells, what is stored
    ksbo-bench run plants-monitor -j 2                     # every cell not yet in the store, 2 processes
    ksbo-bench run plants-monitor --seeds 0-2 --store /tmp/s   # fewer seeds, another store
    ksbo-bench run sitl-short --executor ray --sitl-slots 2    # a local Ray instance with two SITL slots
    ksbo-bench run sitl-short --executor ray --ray-address HOST:6379   # a cluster (ray start on each node)
    ksbo-bench compare STORE_A STORE_B                     # the same cells gave the same records?
    ksbo-bench report                                      # BENCHMARKS.md and benchmarks/pages/*.md
    ksbo-bench report --check                              # exit 1 if a page is not what the stores give

A run resumes: cells whose key is already in the store are skipped (delete their lines to fly them again). A cell
that failed for the infrastructure (a SITL that did not boot) is retried (--retries); one that failed for its own
code gives no record and is said at the end (exit 1); a campaign that crashed or aborted is a record like any.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ksbo_bench.sweep import SweepError, parse_ints


def _where(items: list[str]) -> dict[str, str]:
    out = {}
    for item in items:
        k, sep, v = item.partition("=")
        if not sep:
            raise SweepError(f"--only takes NAME=VALUE, not {item!r}")
        out[k] = v
    return out


def cmd_run(a: argparse.Namespace) -> int:
    from ksbo_bench import driver, sweep as sweeps
    from ksbo_bench.store import Store

    sw = sweeps.load(a.sweep)
    store = Store(a.store or sw.store)
    seeds = parse_ints(a.seeds) if a.seeds else None
    if a.dry_run:
        todo, skipped = driver.pending(sw, store, seeds, _where(a.only))
        for c in todo:
            print(c.id)
        print(f"{len(todo)} to run, {skipped} already in {store.path}", file=sys.stderr)
        return 0
    if a.executor == "ray":
        from ksbo_bench.ray_executor import RayExecutor

        ex = RayExecutor(a.ray_address, a.jobs, a.sitl_slots, a.retries)
    else:
        from ksbo_bench.local_executor import LocalExecutor

        ex = LocalExecutor(a.jobs or 1, a.sitl_slots, a.retries)
    summ = driver.run(sw, ex, store, seeds, _where(a.only))
    for line in summ.failed:
        print(f"no record: {line}", file=sys.stderr)
    return 1 if summ.failed else 0


def cmd_list(a: argparse.Namespace) -> int:
    from ksbo_bench import sweep as sweeps
    from ksbo_bench.store import Store

    for sw in sweeps.all_sweeps():
        cells = sw.cells()
        done = Store(sw.store).done()
        what = (f"{len(done):5d} records (archive)  " if sw.archive else
                f"{len(cells):5d} cells, {sum(c.id in done for c in cells):5d} stored  ")
        print(f"{sw.name:24s} {sw.kind:9s} {what}{sw.title}")
    return 0


def cmd_compare(a: argparse.Namespace) -> int:
    from ksbo_bench.store_compare import compare

    text, same = compare(Path(a.a), Path(a.b))
    print(text)
    return 0 if same else 1


def cmd_report(a: argparse.Namespace) -> int:
    from ksbo_bench.report.pages import main as report_main

    return report_main(check=a.check)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="ksbo-bench", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="run a sweep's cells that are not in its store yet")
    r.add_argument("sweep", help="a sweep file, or its name in benchmarks/sweeps/")
    r.add_argument("--executor", choices=("local", "ray"), default="local",
                   help="local: this machine's processes (default); ray: one Ray task per cell")
    r.add_argument("-j", "--jobs", type=int, default=None,
                   help="cells at once (local: processes, default 1; ray on this machine: CPUs, default all)")
    r.add_argument("--seeds", help="replace the sweep's seeds, e.g. 0-2 or 0,5,7")
    r.add_argument("--store", help="the store directory (default: the sweep's, under benchmarks/store/)")
    r.add_argument("--only", action="append", default=[], metavar="NAME=VALUE",
                   help="only the cells with this value (repeatable), e.g. --only plant=nominal")
    r.add_argument("--sitl-slots", type=int, default=1,
                   help="SITLs at once on this machine (local, or a Ray instance started here; default 1); on a "
                        "cluster each node declares its own with ray start --resources '{\"sitl\": N}'")
    r.add_argument("--ray-address", help="a running Ray cluster (HOST:PORT or auto); default: start one here")
    r.add_argument("--retries", type=int, default=2, help="re-runs of a cell the infrastructure failed (default 2)")
    r.add_argument("--dry-run", action="store_true", help="list the keys of the cells to run; run nothing")
    r.set_defaults(fn=cmd_run)
    sub.add_parser("list", help="the sweeps and what their stores hold").set_defaults(fn=cmd_list)
    c = sub.add_parser("compare", help="whether two stores hold the same records for the same cells")
    c.add_argument("a")
    c.add_argument("b")
    c.set_defaults(fn=cmd_compare)
    p = sub.add_parser("report", help="write BENCHMARKS.md and one page per sweep from the stores")
    p.add_argument("--check", action="store_true", help="write nothing; exit 1 if a page is out of date")
    p.set_defaults(fn=cmd_report)
    a = ap.parse_args(argv)
    try:
        return a.fn(a)
    except (SweepError, RuntimeError) as e:
        print(f"ksbo-bench: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("ksbo-bench: interrupted; the records written so far are kept, a new run resumes", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
