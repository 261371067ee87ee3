#!/usr/bin/env python3
"""Seeds ../fuzz/corpus/ (the imc_packet fuzz target) from imcpy's packets in
../fixtures/imcpy_packets.hex: each packet alone, and broken ways a link delivers them (bad
CRC, truncated, noise around, a big-endian packet, an oversized header, lists and nesting past
the codec's bounds, all packets in a row). Needs no imcpy.

    python3 vehicles/dune/python/make_corpus.py
"""

import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "fuzz", "corpus")


def crc16(b):
    c = 0
    for x in b:
        c ^= x
        for _ in range(8):
            c = (c >> 1) ^ 0xA001 if c & 1 else c >> 1
    return c


def packet(mgid, payload, big=False, src=0x00D1, dst=0xFFFF):
    e = ">" if big else "<"
    body = struct.pack(e + "HHHdHBHB", 0xFE54, mgid, len(payload), 1.7e9, src, 0, dst, 0xFF) + payload
    return body + struct.pack(e + "H", crc16(body))


def main():
    os.makedirs(OUT, exist_ok=True)
    rows = {}
    for line in open(os.path.join(HERE, "..", "fixtures", "imcpy_packets.hex")):
        if line.startswith("#") or not line.strip():
            continue
        name, h = line.split()
        rows[name] = bytes.fromhex(h)
    seeds = dict(rows)
    seeds["all_in_a_row"] = b"".join(rows.values())
    es = rows["estimated_state"]
    seeds["bad_crc_then_good"] = es[:-1] + bytes([es[-1] ^ 0xFF]) + es
    seeds["truncated_then_good"] = es[:30] + es
    seeds["noise_around"] = b"\x00\xffnoise\x54" + es + b"\xfe\x54\x01"
    seeds["big_endian_abort"] = packet(550, b"", big=True)
    seeds["big_endian_desired_z"] = packet(401, struct.pack(">fB", 2.0, 1), big=True)
    seeds["oversized_header"] = struct.pack("<HHH", 0xFE54, 350, 60000) + b"\x00" * 200 + es
    seeds["unknown_id"] = packet(1234, b"\x01\x02\x03")
    seeds["list_too_long"] = packet(551, b"\x00\x00" * 3 + struct.pack("<H", 65) + b"\x26\x02" * 65)
    nested = b"\xff\xff"
    for _ in range(6):
        nested = b"\x00\x00" + b"\x30\x02" + nested + b"\x00\x00\x00\x00"  # PlanManeuver in PlanManeuver
    seeds["too_deep"] = packet(552, nested[2:])
    seeds["trailing_payload"] = packet(150, b"\x00")
    seeds["foreign_vehicle_state"] = packet(500, rows["vs_error"][20:-2], src=0x0777)
    for name, b in seeds.items():
        with open(os.path.join(OUT, name), "wb") as f:
            f.write(b)
    print(f"{len(seeds)} seeds in {OUT}")


if __name__ == "__main__":
    main()
