"""Which firmware the vehicle runs and how far this tool has been verified on it, from the one table in
docs/firmware.md (installed as ``ksbo_params/firmware.md``).

At connect the tool says one line: the firmware (AUTOPILOT_VERSION.flight_sw_version), the parameter generation it
found in the parameter list, and the table's verdict for that pair: *flown on SITL here*, *checked against source*
or *not verified*. A release series newer than every verified one of that stack gets a one-line warning before
anything flies. The campaign's plan and report carry the same line.

The table's rows: ``| stack | firmware | parameters | verified | what was checked, where |`` between the
``firmware-table`` markers. ``firmware`` is a version prefix ("4.5", "4.7.0-dev", "1.19.0-dev"; a "-kind" suffix
must match AUTOPILOT_VERSION's release type), ``parameters`` a generation ("legacy", "new") or "any". The most
specific row that matches wins.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources

from ksbo_mav.errors import InputError

VERIFIED = ("flown on SITL here", "checked against source")
NOT_VERIFIED = "not verified"
_BEGIN, _END = "<!-- firmware-table:begin -->", "<!-- firmware-table:end -->"
_KINDS = {0: "dev", 64: "alpha", 128: "beta", 192: "rc", 255: "official"}
_STACK_NAMES = {"ardupilot": "ArduPilot", "px4": "PX4", "ksbo-sim": "ksbo-mav simulator"}


@dataclass(frozen=True)
class Row:
    stack: str
    firmware: str  # version prefix, optionally "-kind"
    parameters: str  # generation or "any"
    verified: str
    checked: str

    def matches(self, version: tuple[int, int, int], kind: str, generation: str) -> bool:
        prefix, _, want_kind = self.firmware.partition("-")
        parts = tuple(int(p) for p in prefix.split("."))
        return (version[:len(parts)] == parts and (not want_kind or want_kind == kind)
                and self.parameters in ("any", generation))

    @property
    def specificity(self) -> tuple[int, int, int]:
        prefix, _, kind = self.firmware.partition("-")
        return len(prefix.split(".")), int(bool(kind)), int(self.parameters != "any")

    @property
    def series(self) -> tuple[int, int]:
        parts = [int(p) for p in self.firmware.partition("-")[0].split(".")] + [0]
        return parts[0], parts[1]


def parse_table(text: str) -> list[Row]:
    """The rows between the markers; :class:`InputError` for a malformed row (the docs page is data)."""
    if _BEGIN not in text or _END not in text:
        raise InputError("firmware table: markers not found")
    rows = []
    for line in text.split(_BEGIN, 1)[1].split(_END, 1)[0].splitlines():
        cells = [c.strip().strip("`") for c in line.strip().strip("|").split("|")]
        if len(cells) != 5 or cells[0] in ("stack", "") or set(cells[0]) <= set("-: "):
            continue
        row = Row(*cells)
        if row.verified not in (*VERIFIED, NOT_VERIFIED) or not re.fullmatch(r"\d+(\.\d+)*(-[a-z]+)?", row.firmware):
            raise InputError(f"firmware table: bad row {line.strip()!r}")
        rows.append(row)
    return rows


@lru_cache(maxsize=1)
def table() -> tuple[Row, ...]:
    return tuple(parse_table(resources.files("ksbo_params").joinpath("firmware.md").read_text(encoding="utf-8")))


def split_version(flight_sw_version: int) -> tuple[tuple[int, int, int], str]:
    v = int(flight_sw_version)
    return (v >> 24 & 0xFF, v >> 16 & 0xFF, v >> 8 & 0xFF), _KINDS.get(v & 0xFF, str(v & 0xFF))


@dataclass(frozen=True)
class FirmwareCheck:
    """The verdict for one vehicle; :attr:`line` and :attr:`warning` are what the console and the report say."""

    stack: str
    version: tuple[int, int, int]
    kind: str
    generation: str  # the table's word ("legacy", "new"); "" when the stack has none to tell
    row: Row | None
    newest_verified: tuple[int, int] | None
    label: str = ""  # the generation in words, for the line

    @property
    def firmware(self) -> str:
        v = ".".join(str(p) for p in self.version)
        return v if self.kind == "official" else f"{v}-{self.kind}"

    @property
    def verified(self) -> str:
        return self.row.verified if self.row else NOT_VERIFIED

    @property
    def line(self) -> str:
        said = self.label or self.generation
        gen = f", parameter generation {said}" if said else ""
        row = f", row {self.row.stack} {self.row.firmware} {self.row.parameters}" if self.row else ""
        return (f"firmware: {_STACK_NAMES.get(self.stack, self.stack)} {self.firmware} (AUTOPILOT_VERSION){gen}, "
                f"verified: {self.verified} (docs/firmware.md{row})")

    @property
    def warning(self) -> str:
        """One line when the release series is newer than every verified one of the stack, else ""."""
        if self.newest_verified is None or self.version[:2] <= self.newest_verified:
            return ""
        newest = ".".join(str(p) for p in self.newest_verified)
        return (f"warning: {_STACK_NAMES.get(self.stack, self.stack)} {self.firmware} is newer than any release "
                f"verified here (newest {newest}): parameter names, modes or failsafes may have changed; watch the "
                "first trials")


#: ArduPilot's generations in words.
ARDUPILOT_LABELS = {"new": "new (PSC_NE_*, PSC_D_*)", "legacy": "legacy (PSC_POSXY_*, PSC_VELZ_*, PSC_ACCZ_*)"}


def check_firmware(stack: str, flight_sw_version: int, generation: str = "", label: str = "",
                   rows: tuple[Row, ...] | list[Row] | None = None) -> FirmwareCheck:
    """The table's verdict for ``stack`` at ``flight_sw_version`` with parameter ``generation`` (the table's word;
    ``label`` says it in words)."""
    rows = table() if rows is None else rows
    version, kind = split_version(flight_sw_version)
    mine = [r for r in rows if r.stack == stack]
    hits = [r for r in mine if r.matches(version, kind, generation or "any")]
    best = max(hits, key=lambda r: r.specificity) if hits else None
    verified = [r.series for r in mine if r.verified in VERIFIED]
    label = label or ARDUPILOT_LABELS.get(generation, "") if stack == "ardupilot" else label
    return FirmwareCheck(stack, version, kind, generation, best, max(verified) if verified else None, label)
