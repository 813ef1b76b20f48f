"""A small MAVLink FTP server: files kept in memory under ``scripts/``, enough for a client to upload, list and
remove a script (what the onboard guard's installer does on ArduPilot).

Reading is served only for the virtual files a vehicle offers (``readable``: path -> a function making its bytes
when it is opened; the simulator offers ``@PARAM/param.pck`` with ``--param-file``): OpenFileRO, BurstReadFile and
ReadFile as ArduPilot's server answers them. Anything else answers "file not found", so a ground station asking for
``@PARAM/param.pck`` falls back to the parameter protocol as before. Replies follow the protocol's header
(seq + 1, the session, ACK/NAK, the request's opcode, the request's offset), as ArduPilot's server does.
"""

from __future__ import annotations

import struct
from collections.abc import Callable

OP_TERMINATE, OP_RESET, OP_LIST, OP_OPEN_RO, OP_READ, OP_CREATE, OP_WRITE, OP_REMOVE = 1, 2, 3, 4, 5, 6, 7, 8
OP_BURST_READ = 15
ACK, NAK = 128, 129
ERR_FAIL, ERR_EOF, ERR_UNKNOWN_COMMAND, ERR_FILE_NOT_FOUND = 1, 6, 7, 10
DIRECTORIES = ("scripts",)
MAX_DATA = 239


class FtpServer:
    """``files``: path -> contents. ``send(payload, target_system, target_component)`` transmits a reply."""

    def __init__(self, send) -> None:
        self.send = send
        self.files: dict[str, bytearray] = {}
        self._writing: str | None = None  # the path the open write session belongs to
        self.readable: dict[str, Callable[[], bytes]] = {}
        self._reading: bytes | None = None  # the file the open read session reads

    def _reply(self, seq: int, session: int, status: int, body: bytes, opcode: int, offset: int,
               burst_complete: int = 0) -> list[int]:
        header = struct.pack("<HBBBBBBI", seq & 0xFFFF, session, status, len(body), opcode, burst_complete, 0,
                             offset)
        payload = list(header + body)
        return payload + [0] * (251 - len(payload))

    def handle(self, msg) -> None:
        req = bytes(msg.payload)
        seq, session, opcode, size, _req, _burst, _pad, offset = struct.unpack_from("<HBBBBBBI", req, 0)
        data = req[12:12 + size]
        if opcode == OP_BURST_READ and self._reading is not None:
            for k, (status, body, at, last) in enumerate(self._burst(offset, size)):
                self.send(self._reply(seq + 1 + k, session, status, body, opcode, at, int(last)),
                          msg.get_srcSystem(), msg.get_srcComponent())
            return
        status, body = self._answer(opcode, data, offset, size)
        self.send(self._reply(seq + 1, session, status, body, opcode, offset), msg.get_srcSystem(),
                  msg.get_srcComponent())

    def _burst(self, offset: int, size: int) -> list[tuple[int, bytes, int, bool]]:
        """A burst read from ``offset``: chunks of ``size`` bytes to the end of the file, then "end of file"."""
        data, size = self._reading or b"", max(1, min(size or MAX_DATA, MAX_DATA))
        out = [(ACK, data[at:at + size], at, False) for at in range(offset, len(data), size)]
        return out + [(NAK, bytes([ERR_EOF]), len(data), True)]

    @staticmethod
    def _path(data: bytes) -> str:
        return data.split(b"\0", 1)[0].decode("ascii", "replace").strip("/")

    def _answer(self, opcode: int, data: bytes, offset: int, size: int = 0) -> tuple[int, bytes]:
        if opcode in (OP_TERMINATE, OP_RESET):
            self._writing = self._reading = None
            return ACK, b""
        if opcode == OP_LIST:
            return self._list(self._path(data), offset)
        if opcode == OP_CREATE:
            path = self._path(data)
            if path.rpartition("/")[0] not in DIRECTORIES:
                return NAK, bytes([ERR_FILE_NOT_FOUND])
            self.files[path] = bytearray()
            self._writing = path
            return ACK, b""
        if opcode == OP_WRITE:
            if self._writing is None:
                return NAK, bytes([ERR_FAIL])
            f = self.files[self._writing]
            if len(f) < offset:
                f.extend(b"\0" * (offset - len(f)))
            f[offset:offset + len(data)] = data
            return ACK, b""
        if opcode == OP_REMOVE:
            path = self._path(data)
            if path not in self.files:
                return NAK, bytes([ERR_FILE_NOT_FOUND])
            del self.files[path]
            return ACK, b""
        if opcode == OP_OPEN_RO:
            make = self.readable.get(data.split(b"\0", 1)[0].decode("ascii", "replace"))
            if make is None:
                return NAK, bytes([ERR_FILE_NOT_FOUND])
            self._reading = make()
            return ACK, struct.pack("<I", len(self._reading))
        if opcode == OP_READ and self._reading is not None:
            chunk = self._reading[offset:offset + min(size or MAX_DATA, MAX_DATA)]
            return (ACK, chunk) if chunk else (NAK, bytes([ERR_EOF]))
        return NAK, bytes([ERR_UNKNOWN_COMMAND])

    def _list(self, directory: str, offset: int) -> tuple[int, bytes]:
        if directory not in DIRECTORIES:
            return NAK, bytes([ERR_FILE_NOT_FOUND])
        entries = [f"F{p.rpartition('/')[2]}\t{len(d)}".encode() for p, d in sorted(self.files.items())
                   if p.rpartition("/")[0] == directory]
        body = b""
        for e in entries[offset:]:
            if len(body) + len(e) + 1 > MAX_DATA:
                break
            body += e + b"\0"
        return (ACK, body) if body else (NAK, bytes([ERR_EOF]))
