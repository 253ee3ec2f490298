"""MAVLink FTP answered without a file server (``shared/mavlink/ftp.py``):
pymavlink encodes the requests and decodes the vehicle's replies, on
CPython and on the MicroPython interpreter (where answering allocates
nothing). MAVProxy against the twin: ``tests/test_mavproxy_twin.py``."""

from __future__ import annotations

import random
import struct

from pymavlink.dialects.v20 import common as pm
from test_mavlink_endpoint import Ground, Vehicle

from roboray.shared.mavlink import ftp
from roboray.shared.mavlink.endpoint import CAPABILITIES, HANDLERS

HEADER = "<HBBBBBBI"      # the FTP payload's header (mavlink.io/en/services/ftp.html "Payload Format")
PATH_OPS = (pm.MAV_FTP_OPCODE_LISTDIRECTORY, pm.MAV_FTP_OPCODE_OPENFILERO, pm.MAV_FTP_OPCODE_CREATEFILE,
            pm.MAV_FTP_OPCODE_REMOVEFILE, pm.MAV_FTP_OPCODE_CREATEDIRECTORY, pm.MAV_FTP_OPCODE_REMOVEDIRECTORY,
            pm.MAV_FTP_OPCODE_OPENFILEWO, pm.MAV_FTP_OPCODE_TRUNCATEFILE, pm.MAV_FTP_OPCODE_RENAME,
            pm.MAV_FTP_OPCODE_CALCFILECRC)
SESSION_OPS = (pm.MAV_FTP_OPCODE_TERMINATESESSION, pm.MAV_FTP_OPCODE_READFILE, pm.MAV_FTP_OPCODE_WRITEFILE,
               pm.MAV_FTP_OPCODE_BURSTREADFILE)
ACK = (pm.MAV_FTP_OPCODE_NONE, pm.MAV_FTP_OPCODE_RESETSESSION)


def request(seq, session, opcode, data=b"", size=None, offset=0):
    """An FTP payload of 251 bytes, as MAVProxy's ``FTP_OP.pack`` makes it."""
    hdr = struct.pack(HEADER, seq, session, opcode, len(data) if size is None else size, 0, 0, 0, offset)
    return list((hdr + data).ljust(251, b"\0"))


def expected(opcode, size):
    """The answer the specification gives a server that has no files and no sessions:
    None for no answer, else (reply opcode, error code or None for an ACK)."""
    if opcode in (pm.MAV_FTP_OPCODE_ACK, pm.MAV_FTP_OPCODE_NAK):
        return None
    if size > 239:
        return pm.MAV_FTP_OPCODE_NAK, pm.MAV_FTP_ERR_INVALIDDATASIZE
    if opcode in ACK:
        return pm.MAV_FTP_OPCODE_ACK, None
    if opcode in SESSION_OPS:
        return pm.MAV_FTP_OPCODE_NAK, pm.MAV_FTP_ERR_INVALIDSESSION
    if opcode in PATH_OPS:
        return pm.MAV_FTP_OPCODE_NAK, pm.MAV_FTP_ERR_FILENOTFOUND if size else pm.MAV_FTP_ERR_INVALIDDATASIZE
    return pm.MAV_FTP_OPCODE_NAK, pm.MAV_FTP_ERR_UNKNOWNCOMMAND


def replies(g, v, n=6):
    v.step(n=n)
    return [m for m in g.received() if m.get_type() == "FILE_TRANSFER_PROTOCOL"]


def decode(m):
    """(seq, session, opcode, size, req_opcode, burst_complete, offset, data) of a reply."""
    raw = bytes(m.payload)
    seq, session, opcode, size, req, burst, _pad, offset = struct.unpack_from(HEADER, raw)
    return seq, session, opcode, size, req, burst, offset, raw[12:]


def ask(g, v, payload, network=0, system=1, component=1):
    g.mav.file_transfer_protocol_send(network, system, component, payload)
    return replies(g, v)


def test_the_opcodes_and_error_codes_are_common_xml_s():
    assert HANDLERS[pm.MAVLINK_MSG_ID_FILE_TRANSFER_PROTOCOL] is ftp.handle
    assert ftp.DATA_MAX == 251 - struct.calcsize(HEADER)
    assert pm.MAVLink_file_transfer_protocol_message.crc_extra == 84
    # no files served: FTP is not claimed
    assert not CAPABILITIES & pm.MAV_PROTOCOL_CAPABILITY_FTP
    source = open(ftp.__file__).read()
    for name, value in (("_OP_NONE", pm.MAV_FTP_OPCODE_NONE),
                        ("_OP_TERMINATE_SESSION", pm.MAV_FTP_OPCODE_TERMINATESESSION),
                        ("_OP_RESET_SESSIONS", pm.MAV_FTP_OPCODE_RESETSESSION),
                        ("_OP_LIST_DIRECTORY", pm.MAV_FTP_OPCODE_LISTDIRECTORY),
                        ("_OP_READ_FILE", pm.MAV_FTP_OPCODE_READFILE), ("_OP_WRITE_FILE", pm.MAV_FTP_OPCODE_WRITEFILE),
                        ("_OP_CALC_FILE_CRC32", pm.MAV_FTP_OPCODE_CALCFILECRC),
                        ("_OP_BURST_READ_FILE", pm.MAV_FTP_OPCODE_BURSTREADFILE), ("_OP_ACK", pm.MAV_FTP_OPCODE_ACK),
                        ("_OP_NAK", pm.MAV_FTP_OPCODE_NAK), ("_ERR_INVALID_DATA_SIZE", pm.MAV_FTP_ERR_INVALIDDATASIZE),
                        ("_ERR_INVALID_SESSION", pm.MAV_FTP_ERR_INVALIDSESSION),
                        ("_ERR_UNKNOWN_COMMAND", pm.MAV_FTP_ERR_UNKNOWNCOMMAND),
                        ("_ERR_FILE_NOT_FOUND", pm.MAV_FTP_ERR_FILENOTFOUND)):
        assert "%s = const(%d)" % (name, value) in source, name


def test_every_opcode_gets_its_answer_addressed_to_the_requester():
    g = Ground()
    v = Vehicle(g)
    replies(g, v, 20)
    path = b"@PARAM/param.pck?withdefaults=1"
    for opcode in range(256):
        seq = 1000 + opcode
        session = (opcode * 7) & 0xFF
        data = path if opcode in PATH_OPS else b""
        got = ask(g, v, request(seq, session, opcode, data, offset=4096))
        want = expected(opcode, len(data))
        if want is None:
            assert got == [], opcode
            continue
        assert len(got) == 1, opcode
        m = got[0]
        # to the ground station that asked, on this network
        assert (m.target_network, m.target_system, m.target_component) == (0, 255, 190)
        assert (m.get_srcSystem(), m.get_srcComponent()) == (1, 1)
        r_seq, r_session, r_op, r_size, r_req, r_burst, r_offset, r_data = decode(m)
        assert (r_seq, r_session, r_req) == (seq + 1, session, opcode), opcode
        assert r_op == want[0], opcode
        if want[1] is None:
            assert r_size == 0 and not any(r_data), opcode
        else:
            assert r_size == 1 and r_data[0] == want[1] and not any(r_data[1:]), opcode
        assert r_offset == 0
        assert r_burst == (opcode == pm.MAV_FTP_OPCODE_BURSTREADFILE)
    # MAVProxy's parameter download: OpenFileRO of @PARAM/param.pck, refused at once
    got = ask(g, v, request(0, 78, pm.MAV_FTP_OPCODE_OPENFILERO, path))
    assert [decode(m)[2:5] for m in got] == [(pm.MAV_FTP_OPCODE_NAK, 1, pm.MAV_FTP_OPCODE_OPENFILERO)]
    assert decode(got[0])[7][0] == pm.MAV_FTP_ERR_FILENOTFOUND


def test_sequence_numbers_wrap_at_16_bits_and_a_resent_request_gets_the_same_reply():
    g = Ground()
    v = Vehicle(g)
    replies(g, v, 20)
    assert decode(ask(g, v, request(0xFFFF, 3, pm.MAV_FTP_OPCODE_NONE))[0])[0] == 0
    assert decode(ask(g, v, request(255, 3, pm.MAV_FTP_OPCODE_NONE))[0])[0] == 256
    # the same request again (its reply lost): the same reply
    a = ask(g, v, request(41, 9, pm.MAV_FTP_OPCODE_LISTDIRECTORY, b"/"))
    b = ask(g, v, request(41, 9, pm.MAV_FTP_OPCODE_LISTDIRECTORY, b"/"))
    assert len(a) == len(b) == 1 and bytes(a[0].payload) == bytes(b[0].payload)
    assert decode(a[0])[:5] == (42, 9, pm.MAV_FTP_OPCODE_NAK, 1, pm.MAV_FTP_OPCODE_LISTDIRECTORY)


def test_a_request_for_another_system_component_or_network_is_ignored_and_broadcast_answered():
    g = Ground()
    v = Vehicle(g)
    replies(g, v, 20)
    req = request(5, 1, pm.MAV_FTP_OPCODE_OPENFILERO, b"/x")
    for network, system, component in ((0, 2, 1), (0, 1, 2), (1, 1, 1), (255, 0, 0), (0, 255, 0)):
        assert ask(g, v, req, network, system, component) == [], (network, system, component)
    for system, component in ((0, 0), (1, 0), (0, 1)):
        got = ask(g, v, req, 0, system, component)
        assert [decode(m)[2] for m in got] == [pm.MAV_FTP_OPCODE_NAK], (system, component)


def test_malformed_sizes_and_payloads_get_invalid_data_size_or_nothing_never_an_exception():
    g = Ground()
    v = Vehicle(g)
    replies(g, v, 20)
    # size past the 239 data bytes, on every kind of opcode
    for opcode in (pm.MAV_FTP_OPCODE_NONE, pm.MAV_FTP_OPCODE_RESETSESSION, pm.MAV_FTP_OPCODE_OPENFILERO,
                   pm.MAV_FTP_OPCODE_WRITEFILE, 99):
        for size in (240, 255):
            got = ask(g, v, request(7, 2, opcode, b"abc", size=size))
            assert [(decode(m)[2], decode(m)[7][0]) for m in got] == [
                (pm.MAV_FTP_OPCODE_NAK, pm.MAV_FTP_ERR_INVALIDDATASIZE)], (opcode, size)
    # a path operation with no path
    got = ask(g, v, request(8, 2, pm.MAV_FTP_OPCODE_REMOVEFILE, b"", size=0))
    assert decode(got[0])[7][0] == pm.MAV_FTP_ERR_INVALIDDATASIZE
    # a reply coming in, even a malformed one, is not answered
    for opcode in (pm.MAV_FTP_OPCODE_ACK, pm.MAV_FTP_OPCODE_NAK):
        assert ask(g, v, request(9, 2, opcode, b"", size=255)) == []
    # random payloads (MAVLink 2 cuts the trailing zeros: every length on the
    # wire): at most one reply each, and the one the rule gives
    rng = random.Random(27)
    answered = 0
    for k in range(300):
        payload = [rng.randrange(256) for _ in range(rng.randrange(0, 252))]
        payload = (payload + [0] * 251)[:251]
        got = ask(g, v, payload)
        opcode, size = payload[3], payload[4]
        want = expected(opcode, size)
        assert len(got) == (0 if want is None else 1), k
        if got:
            answered += 1
            r = decode(got[0])
            assert r[0] == (payload[0] + 256 * payload[1] + 1) & 0xFFFF and r[1] == payload[2] and r[4] == opcode
            assert (r[2], r[7][0] if want[1] is not None else None) == want, k
    assert answered > 250
    # the link still works: a PARAM_REQUEST_READ is answered
    g.mav.param_request_read_send(1, 1, b"SYSID_THISMAV", -1)
    v.step(n=6)
    assert [m.param_id for m in g.received() if m.get_type() == "PARAM_VALUE"] == ["SYSID_THISMAV"]


def test_signed_link_answers_signed_and_refuses_unsigned_ftp():
    from test_mavlink_endpoint import KEY
    g = Ground(key=KEY)
    v = Vehicle(g, key=KEY)
    replies(g, v, 20)
    got = ask(g, v, request(1, 1, pm.MAV_FTP_OPCODE_OPENFILERO, b"/x"))
    assert len(got) == 1 and got[0].get_signed()
    plain = Ground()
    v.ep.transport = plain.pipe
    assert ask(plain, v, request(1, 1, pm.MAV_FTP_OPCODE_OPENFILERO, b"/x")) == []


_MP_SETUP = """
from roboray.shared import param_defs, modes
from roboray.shared.params import ParamTable
from roboray.shared.mavlink import ftp
from roboray.shared.mavlink.endpoint import Endpoint
from roboray.shared.mavlink.telemetry import Telemetry
class __Pipe:
    # keeps the writer's view of the frame sent (a copy would allocate)
    def __init__(self):
        self.last = None
    def read_into(self, buf):
        return 0
    def write(self, buf):
        self.last = buf
__pipe = __Pipe()
__ep = Endpoint(__pipe, ParamTable(param_defs.PARAMS), modes.Modes(), Telemetry())
__p = __ep.parser
def __parse(frame):
    __p.feed(frame, 0, len(frame))
    return __p.ready
"""


def test_the_answers_on_micropython_allocate_nothing(micropython):
    """The board's handler on the real interpreter: the same replies, and
    answering a request takes no heap (the reply is packed into the writer's buffer)."""
    mav = pm.MAVLink(None, 255, 190)
    rx = pm.MAVLink(None)
    micropython.exec(_MP_SETUP)
    cases = [(0, pm.MAV_FTP_OPCODE_NONE, b""), (1, pm.MAV_FTP_OPCODE_OPENFILERO, b"@PARAM/param.pck?withdefaults=1"),
             (2, pm.MAV_FTP_OPCODE_READFILE, b""), (3, 16, b"/"), (0xFFFF, pm.MAV_FTP_OPCODE_LISTDIRECTORY, b""),
             (5, pm.MAV_FTP_OPCODE_NONE, b"x" * 10)]
    for seq, opcode, data in cases:
        frame = pm.MAVLink_file_transfer_protocol_message(0, 1, 1, request(seq, 4, opcode, data)).pack(mav)
        micropython.exec("__f = %r" % frame)
        assert micropython.eval("__parse(__f)")
        micropython.exec("ftp.handle(__ep, __p)")      # (the writer's view of this frame length: made once)
        used = micropython.alloc_bytes("ftp.handle(__ep, __p)")
        assert used == 0, (opcode, used)
        out = micropython.eval("bytes(__pipe.last)")
        m = rx.parse_char(out)
        assert m is not None and m.get_type() == "FILE_TRANSFER_PROTOCOL"
        want = expected(opcode, len(data))
        r = decode(m)
        assert (r[0], r[1], r[2], r[4]) == ((seq + 1) & 0xFFFF, 4, want[0], opcode)
        assert (r[7][0] if want[1] is not None else None) == want[1]
    # a reply coming in: nothing sent
    micropython.exec("__pipe.last = None")
    frame = pm.MAVLink_file_transfer_protocol_message(0, 1, 1, request(9, 4, pm.MAV_FTP_OPCODE_NAK)).pack(mav)
    micropython.exec("__f = %r" % frame)
    assert micropython.eval("__parse(__f)")
    micropython.exec("ftp.handle(__ep, __p)")
    assert micropython.eval("__pipe.last is None")
