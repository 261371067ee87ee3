"""Decodes every message of an MCAP recording with the reference Python reader (mcap +
mcap-protobuf-support), using only the schemas stored in the file. Prints one JSON object:
{"messages": N, "topics": {topic: count}, "first": {topic: {field: value}}}. Exits 1 if any
message fails to decode."""
import json
import sys

from google.protobuf.json_format import MessageToDict
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory


def main(path: str) -> int:
    topics: dict[str, int] = {}
    first: dict[str, dict] = {}
    n = 0
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message, proto in reader.iter_decoded_messages():
            if schema is None or schema.encoding != "protobuf" or channel.message_encoding != "protobuf":
                print(f"not protobuf: {channel.topic}", file=sys.stderr)
                return 1
            if proto.DESCRIPTOR.full_name != schema.name:
                print(f"{channel.topic}: decoded as {proto.DESCRIPTOR.full_name}, schema {schema.name}", file=sys.stderr)
                return 1
            n += 1
            topics[channel.topic] = topics.get(channel.topic, 0) + 1
            if channel.topic not in first:
                first[channel.topic] = MessageToDict(proto, preserving_proto_field_name=True)
    print(json.dumps({"messages": n, "topics": topics, "first": first}))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
