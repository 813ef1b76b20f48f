"""A small MAVLink FTP server: files kept in memory under ``scripts/``, enough for a client to upload, list and
remove a script (what the onboard guard's installer does on ArduPilot).

Reading files is not served (OpenFileRO answers "file not found"), so a ground station asking for
``@PARAM/param.pck`` falls back to the parameter protocol as before. Replies follow the protocol's header
(seq + 1, the session, ACK/NAK, the request's opcode, the request's offset), as ArduPilot's server does.
"""

from __future__ import annotations

import struct

OP_TERMINATE, OP_RESET, OP_LIST, OP_OPEN_RO, OP_CREATE, OP_WRITE, OP_REMOVE = 1, 2, 3, 4, 6, 7, 8
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

    def handle(self, msg) -> None:
        req = bytes(msg.payload)
        seq, session, opcode, size, _req, _burst, _pad, offset = struct.unpack_from("<HBBBBBBI", req, 0)
        data = req[12:12 + size]
        reply = self._answer(opcode, data, offset)
        status, body = reply
        header = struct.pack("<HBBBBBBI", (seq + 1) & 0xFFFF, session, status, len(body), opcode, 0, 0, offset)
        payload = list(header + body)
        self.send(payload + [0] * (251 - len(payload)), msg.get_srcSystem(), msg.get_srcComponent())

    @staticmethod
    def _path(data: bytes) -> str:
        return data.split(b"\0", 1)[0].decode("ascii", "replace").strip("/")

    def _answer(self, opcode: int, data: bytes, offset: int) -> tuple[int, bytes]:
        if opcode in (OP_TERMINATE, OP_RESET):
            self._writing = None
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
            return NAK, bytes([ERR_FILE_NOT_FOUND])
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
