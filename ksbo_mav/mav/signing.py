"""MAVLink 2 signing: the secret key a signed vehicle expects, read from a file and kept out of every output.

Key file (``--signing-key FILE`` or ``$KSBO_SIGNING_KEY_FILE``): either the 32 raw key bytes, or one line of text,
a passphrase, turned into the key by SHA-256 as MAVProxy's ``signing setup PASSPHRASE`` does (so the passphrase
given to MAVProxy, or to ArduPilot through it, works here unchanged). A file of exactly 32 printable characters
could be either and is refused: end a passphrase with a newline.

Timestamps follow the protocol: 10 µs units since 2015-01-01 00:00 UTC, starting at this computer's clock,
one step up per frame sent, and never below the newest timestamp heard from the vehicle (pymavlink raises its own
to every correctly signed frame it receives), so a computer whose clock is behind (no real-time clock) still sends
timestamps the vehicle accepts once it has heard the vehicle. Unsigned frames are accepted from the radio only
(RADIO_STATUS: telemetry radios cannot sign), as MAVProxy does.

The key lives in :class:`SigningKey` only, whose ``repr`` hides it; frames carry a signature, never the key, so
the tlog holds none of it.
"""

from __future__ import annotations

import hashlib
import os
import string
from pathlib import Path
from typing import Any

from ksbo_mav.errors import InputError

ENV_VAR = "KSBO_SIGNING_KEY_FILE"
KEY_BYTES = 32
#: Seconds from 1970-01-01 to 2015-01-01, the signing timestamp's epoch.
EPOCH_2015 = 1420070400
#: Our link id in the signature (one stream per sysid/compid/link id on the vehicle's side).
LINK_ID = 0
_PRINTABLE = set(string.printable.encode())


class SigningKey:
    """The 32-byte secret; ``source`` names where it came from (a path, never the key)."""

    def __init__(self, secret: bytes, source: str) -> None:
        if len(secret) != KEY_BYTES:
            raise InputError(f"a MAVLink signing key has {KEY_BYTES} bytes, got {len(secret)}")
        self._secret = bytes(secret)
        self.source = source

    @property
    def secret(self) -> bytes:
        return self._secret

    def __repr__(self) -> str:
        return f"SigningKey(from {self.source})"

    __str__ = __repr__

    @classmethod
    def from_file(cls, path: str | Path, option: str = "--signing-key") -> "SigningKey":
        p = Path(path)
        try:
            data = p.read_bytes()
        except OSError as exc:
            raise InputError(f"{option} {path}: cannot read it ({exc.strerror or exc})") from None
        if len(data) == KEY_BYTES and all(b in _PRINTABLE for b in data):
            raise InputError(f"{option} {path}: 32 printable characters could be a raw key or a passphrase; end a "
                             "passphrase with a newline (a raw key is 32 bytes from e.g. `head -c 32 /dev/urandom`)")
        if len(data) == KEY_BYTES:
            return cls(data, str(p))
        text = data.decode("utf-8", errors="strict") if _is_text(data) else None
        passphrase = text.rstrip("\r\n") if text is not None else ""
        if not passphrase or "\n" in passphrase:
            raise InputError(f"{option} {path}: neither 32 raw key bytes nor one line of passphrase "
                             f"({len(data)} bytes)")
        return cls(hashlib.sha256(passphrase.encode("utf-8")).digest(), str(p))


def _is_text(data: bytes) -> bool:
    try:
        data.decode("utf-8")
    except UnicodeDecodeError:
        return False
    return True


def key_from(path: str | None, env: dict[str, str] | None = None) -> SigningKey | None:
    """The key from ``--signing-key`` (``path``), else from the file ``$KSBO_SIGNING_KEY_FILE`` names, else None."""
    env = os.environ if env is None else env
    if path:
        return SigningKey.from_file(path)
    if env.get(ENV_VAR):
        return SigningKey.from_file(env[ENV_VAR], f"${ENV_VAR}")
    return None


def _unsigned_from_radio(_mav: Any, msg_id: int) -> bool:
    from ksbo_mav.mav.wire import mavlink

    return msg_id == mavlink.MAVLINK_MSG_ID_RADIO_STATUS


def start_signing(conn: Any, key: SigningKey, now_unix: float) -> None:
    """Sign everything ``conn`` (a pymavlink connection) sends with ``key`` and check what it receives."""
    timestamp = int(max(now_unix - EPOCH_2015, 0) * 100_000)
    conn.setup_signing(key.secret, sign_outgoing=True, allow_unsigned_callback=_unsigned_from_radio,
                       initial_timestamp=timestamp, link_id=LINK_ID)


NEEDS_KEY = (f"the vehicle signs its MAVLink traffic (MAVLink 2 signing) and ignores unsigned commands: give its "
             f"key with --signing-key FILE or ${ENV_VAR} (32 raw bytes or a passphrase line; "
             "docs/flight-checklist.md, \"A signed link\")")


def needs_key(link: Any) -> str | None:
    """The one-line reason when the vehicle signs its link (a frame with the signature flag arrived) and
    ``link`` (a :class:`~ksbo_mav.mav.link.Link`) has no key; else None."""
    return NEEDS_KEY if link.signed_seen and link.endpoint.signing is None else None
