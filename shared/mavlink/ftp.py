"""MAVLink FTP (FILE_TRANSFER_PROTOCOL) answered without a file server.

MAVProxy fetches parameters by FTP first (``@PARAM/param.pck``, at connect
and on ``param fetch``) and falls back to PARAM_REQUEST_LIST only when the
request fails. Unanswered, it sent OpenFileRO 11 times, a second apart,
and printed ``FTP: request timed out``: ~11 s at every connect. RoboRay
serves no files over MAVLink (the flight log goes by LOG_REQUEST_*,
``logs``), so every request gets the protocol's refusal at once, and
MAVProxy reads a NAK to OpenFileRO as "open failed" and asks for the
parameter list.
AUTOPILOT_VERSION does not claim MAV_PROTOCOL_CAPABILITY_FTP.

The answers follow the FTP specification (mavlink.io/en/services/ftp.html,
"OpCodes/Command" and "NAK Error Information"); opcodes and error codes
are common.xml's MAV_FTP_OPCODE and MAV_FTP_ERR:

- None: ACK (the specification: "ignored, always ACKed"); ResetSessions:
  ACK with no data (the specification's answer; there is nothing to close);
- TerminateSession, ReadFile, WriteFile, BurstReadFile: NAK InvalidSession,
  "session is not currently open": no session is ever opened (the
  specification's source notes that ResetSessions is TerminateSession
  without its check that the session exists);
- the opcodes that name a path (ListDirectory, OpenFileRO, CreateFile,
  RemoveFile, CreateDirectory, RemoveDirectory, OpenFileWO, TruncateFile,
  Rename, CalcFileCRC32): NAK FileNotFound, no path names a file or a
  directory here, the root included (a create's parent is missing: POSIX
  ENOENT); with no path at all (``size`` 0): InvalidDataSize;
- any other opcode (MAVProxy's ListDirectoryWithTime, 16, too, on which
  it falls back to ListDirectory): NAK UnknownCommand;
- ``size`` past the 239 data bytes a frame carries: NAK InvalidDataSize;
- an ACK or a NAK coming in: no answer (a reply to a reply would go back
  and forth between two servers);
- a frame for another network, system or component: nothing.

A reply is addressed to the requester (its system and component), carries
the request's ``session`` and ``seq_number + 1`` (modulo 2**16, the field's
width), the request's opcode in ``req_opcode``, ``size`` 0 (ACK) or 1 with
the error code in ``data[0]`` (NAK), ``offset`` 0 and ``burst_complete`` 1
for a BurstReadFile (no burst packets follow). The answer is a function of
the request alone, so a request sent again with the same sequence number
gets the same reply, which the specification asks of a server.

Allocation: one ``struct.pack_into`` into the writer's buffer (the data
bytes zeroed by the format's ``239s``), nothing on the heap.
"""

import struct

from roboray.shared.mavlink import messages as msg

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

# MAV_FTP_OPCODE (common.xml)
_OP_NONE = const(0)
_OP_TERMINATE_SESSION = const(1)
_OP_RESET_SESSIONS = const(2)
_OP_LIST_DIRECTORY = const(3)
_OP_READ_FILE = const(5)
_OP_WRITE_FILE = const(7)
_OP_CALC_FILE_CRC32 = const(14)
_OP_BURST_READ_FILE = const(15)
_OP_ACK = const(128)
_OP_NAK = const(129)
# MAV_FTP_ERR (common.xml)
_ERR_INVALID_DATA_SIZE = const(3)
_ERR_INVALID_SESSION = const(4)
_ERR_UNKNOWN_COMMAND = const(7)
_ERR_FILE_NOT_FOUND = const(10)

#: Data bytes an FTP payload carries: FILE_TRANSFER_PROTOCOL's 251 less the 12-byte header.
DATA_MAX = const(239)
# FILE_TRANSFER_PROTOCOL's target_network, target_system, target_component,
# then the FTP header (seq_number, session, opcode, size, req_opcode,
# burst_complete, padding, offset) and its data, zero-filled by "239s"
_REPLY_FMT = "<BBBHBBBBBBI239s"
_DATA_AT = const(15)      # data[0] in FILE_TRANSFER_PROTOCOL's payload


def handle(ep, p):
    """FILE_TRANSFER_PROTOCOL: an ACK or NAK to a request for us (module docstring)."""
    pl = p.payload
    # target_network 0: this link, not a network behind it
    if pl[0] != 0 or not ep._for_us(pl[1], pl[2]):
        return
    op = pl[6]
    if op == _OP_ACK or op == _OP_NAK:
        return
    size = pl[7]
    if size > DATA_MAX:
        err = _ERR_INVALID_DATA_SIZE
    elif op == _OP_NONE or op == _OP_RESET_SESSIONS:
        err = 0
    elif op == _OP_TERMINATE_SESSION or op == _OP_READ_FILE or op == _OP_WRITE_FILE or op == _OP_BURST_READ_FILE:
        err = _ERR_INVALID_SESSION
    elif _OP_LIST_DIRECTORY <= op <= _OP_CALC_FILE_CRC32:   # the rest of 3-14 name a path
        err = _ERR_FILE_NOT_FOUND if size else _ERR_INVALID_DATA_SIZE
    else:
        err = _ERR_UNKNOWN_COMMAND
    w = ep.writer
    struct.pack_into(_REPLY_FMT, w.buf, w.payload, 0, p.sysid, p.compid, ((pl[3] | (pl[4] << 8)) + 1) & 0xFFFF,
                     pl[5], _OP_NAK if err else _OP_ACK, 1 if err else 0, op,
                     1 if op == _OP_BURST_READ_FILE else 0, 0, 0, b"")
    if err:
        w.buf[w.payload + _DATA_AT] = err
    ep._send(msg.MSG_FILE_TRANSFER_PROTOCOL)
