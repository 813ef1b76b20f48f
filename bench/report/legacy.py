"""The benchmarks whose output is still a Markdown file written by their own script under benchmarks/ (not a sweep
yet: see docs/benchmarks.md): BENCHMARKS.md shows each one's introduction and first table."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
BENCH = ROOT / "benchmarks"

#: (section title, output under benchmarks/, extra text; "linked": only linked from a list at the end).
MARKDOWN_OUTPUTS: list[tuple[str, str, str]] = [
    ("MAVLink tuning campaign on the built-in vehicle", "mavlink-campaign/results.md", ""),
    ("Warm start from a finished campaign", "warm-start/results.md", ""),
    ("A vehicle that changes: drift, wind, the re-flights' cost", "drift/results.md",
     "Reading: [docs/optimizer.md](docs/optimizer.md), its section on a vehicle that changes."),
    ("Campaigns at real time, with realistic sensor noise, and their validation", "realtime-campaign/results.md",
     "Settings and reasons: [benchmarks/notes/realtime-sensors.md](benchmarks/notes/realtime-sensors.md)."),
    ("The training figure-8 against the flights pilots fly", "training-vs-flown/results.md",
     "Reading: [docs/training-trial.md](docs/training-trial.md)."),
    ("A campaign through a radio-like link", "link-campaign/results.md",
     "Reading: [docs/links.md](docs/links.md), its sections on the radio end to end."),
    ("The same gains at 50, 20 and 10 Hz", "link-rates/results.md", "Reading: [docs/links.md](docs/links.md)."),
] + [(title, rel, "linked") for title, rel in (
    ("Kernel selection: speed, recovery of known orders, stability over priors", "kernel-selection/results.md"),
    ("Planar task landscape around a0: best E[P] within a radius, risk on the way", "landscape/results.md"),
    ("Planar simulator: speed, task statistics", "simulator/results.md"),
    ("JSBSim 3-D copter: real-time factor, tracking against gains", "copter3d/results.md"),
    ("MAVLink simulator: a figure-8 in lockstep, round trip per step", "mavlink-sim/results.md"),
    ("Flight-log scoring: throughput and memory on a 500 MB log", "log-scoring/results.md"),
    ("The first SITL campaigns (2026-11-30, the paper's method, no prior)", "sitl-campaign/results.md"),
    ("An onboard trial", "onboard-trial/results.md"),
)]


def _blocks(text: str) -> list[str]:
    """``text`` split into blank-line separated blocks (a table is one block)."""
    return [b.strip("\n") for b in text.split("\n\n") if b.strip()]


#: A headline table's rows at most (the full output has the rest).
MAX_ROWS = 6


def cap(table: str, rows: int = MAX_ROWS) -> str:
    lines = table.splitlines()
    if len(lines) <= rows + 2:
        return table
    return "\n".join(lines[:rows + 2]) + f"\n\n({len(lines) - rows - 2} more rows in the full output)"


def headline(path: Path, tables: int = 1) -> str:
    """The blocks of a Markdown output up to and including its first ``tables`` tables (each at most
    :data:`MAX_ROWS` rows), the prose before the first table cut to its first paragraph, the one naming the
    machine and the last; headings
    (``#``) are dropped except ``###`` ones directly before a kept table, which become bold captions."""
    out: list[str] = []
    seen = 0
    for block in _blocks(path.read_text()):
        if block.startswith("## ") or block.startswith("# "):
            continue
        if block.startswith("### "):
            out.append(f"**{block[4:].strip()}**")
            continue
        if block.lstrip().startswith("|"):
            if not seen and len(out) > 2:  # the first paragraph, the machine's and the one before the table
                out = [b for i, b in enumerate(out) if i in (0, len(out) - 1) or "Machine" in b]
            out.append(cap(block))
            seen += 1
            if seen == tables:
                break
        else:
            out.append(block)
    return "\n\n".join(out)


def section(title: str, rel: str, extra: str = "") -> str:
    path = BENCH / rel
    link = f"Full output: [benchmarks/{rel}](benchmarks/{rel})."
    return "\n\n".join(x for x in (f"## {title}", headline(path), extra, link) if x)


def sections() -> list[str]:
    """A section with the headline of each output, then one list of the outputs linked only."""
    out = [section(*row) for row in MARKDOWN_OUTPUTS if row[2] != "linked"]
    linked = [f"- {title}: [benchmarks/{rel}](benchmarks/{rel})" for title, rel, extra in MARKDOWN_OUTPUTS
              if extra == "linked" and (BENCH / rel).is_file()]
    return out + ["## More results\n\n" + "\n".join(linked)] if linked else out
