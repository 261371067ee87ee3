"""Helpers shared by the imcpy scripts: building messages field by field (imcpy's enum fields
take their enum type, not an int) and cutting a byte stream into IMC packets."""

import math
import struct

import imcpy


def setf(msg, name, value):
    """msg.name = value, converting an int to the field's enum/bitfield type when needed."""
    try:
        setattr(msg, name, value)
    except TypeError:
        setattr(msg, name, type(getattr(msg, name))(value))


def make(cls, src, dst, timestamp, src_ent=0xFF, dst_ent=0xFF, **fields):
    m = cls()
    m.src = src
    m.dst = dst
    m.src_ent = src_ent
    m.dst_ent = dst_ent
    m.timestamp = timestamp
    for k, v in fields.items():
        setf(m, k, v)
    return m


def serialize(m):
    return bytes(imcpy.Packet.serialize(m))


def deserialize(b):
    return imcpy.Packet.deserialize(b)


def desired_speed(value):
    return make(imcpy.DesiredSpeed, 0xFFFF, 0xFFFF, 0.0, value=value, speed_units=0)


def desired_z(value):
    return make(imcpy.DesiredZ, 0xFFFF, 0xFFFF, 0.0, value=value, z_units=1)


class Cutter:
    """IMC packets from a stream (little- or big-endian sync); imcpy checks the CRC."""

    def __init__(self):
        self.buf = b""

    def feed(self, data):
        self.buf += data
        out = []
        while True:
            i = min([j for j in (self.buf.find(b"\x54\xfe"), self.buf.find(b"\xfe\x54")) if j >= 0],
                    default=-1)
            if i < 0:
                self.buf = self.buf[-1:]
                return out
            self.buf = self.buf[i:]
            if len(self.buf) < 20:
                return out
            fmt = "<H" if self.buf[0] == 0x54 else ">H"
            size = struct.unpack(fmt, self.buf[4:6])[0]
            total = 22 + size
            if len(self.buf) < total:
                return out
            pkt, self.buf = self.buf[:total], self.buf[total:]
            try:
                out.append(deserialize(pkt))
            except Exception:  # a bad packet: skip its sync word and search again
                self.buf = pkt[2:] + self.buf


def displace(lat, lon, north, east):
    """Flat-earth displacement in radians (the facts file: fine for offsets under 1 km)."""
    a, e2 = 6378137.0, 6.69437999014e-3
    s = math.sin(lat)
    rn = a / math.sqrt(1 - e2 * s * s)
    rm = rn * (1 - e2) / (1 - e2 * s * s)
    return lat + north / rm, lon + east / (rn * math.cos(lat))
