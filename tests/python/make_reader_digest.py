"""Opens an MCAP file the way Foxglove's scripts and most tools do: the `mcap` package's
make_reader on a seekable file (its SeekingReader: footer, summary, chunk indexes), and reads
every message. Prints one JSON object:
  {"ok": true, "messages": N, "digest": D, "topics": {topic: count}}
where D is the sum (mod 2**64) of the CRC-32 of each message's topic, NUL, sequence (u32 LE),
log time (u64 LE) and bytes -- the digest `frontseat_record::crafted::message_digest` computes.
If the reader fails (a file a crash left without its summary), prints
  {"ok": false, "error": "<exception>"}
and exits 3. Used by tests/record_recover.rs and record/tests/record_recover.rs."""
import json
import struct
import sys
import zlib

from mcap.reader import make_reader


def main(path: str) -> int:
    n = 0
    digest = 0
    topics: dict[str, int] = {}
    try:
        with open(path, "rb") as f:
            reader = make_reader(f)
            for _schema, channel, message in reader.iter_messages(log_time_order=False):
                key = (
                    channel.topic.encode()
                    + b"\0"
                    + struct.pack("<IQ", message.sequence, message.log_time)
                    + message.data
                )
                digest = (digest + zlib.crc32(key)) % (1 << 64)
                n += 1
                topics[channel.topic] = topics.get(channel.topic, 0) + 1
    except Exception as e:  # noqa: BLE001 -- any failure of the reader is the answer
        print(json.dumps({"ok": False, "error": f"{type(e).__name__}: {e}"}))
        return 3
    print(json.dumps({"ok": True, "messages": n, "digest": digest, "topics": topics}))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
