"""Decodes AIS sentences with pyais (the reference decoder, PyPI pyais==3.3.1): one sentence per
line on stdin (single-fragment `!AIVDM`), one JSON object per line on stdout with the decoded
fields, or {"error": ...} for a sentence pyais refuses. Used by tests/opencpn_ais.rs."""
import json
import sys

import pyais

for line in sys.stdin:
    line = line.strip()
    if not line:
        continue
    try:
        msg = pyais.decode(line).asdict()
        out = {k: (v.decode() if isinstance(v, bytes) else (int(v) if hasattr(v, "value") else v))
               for k, v in msg.items()}
        print(json.dumps(out, default=str))
    except Exception as e:  # noqa: BLE001 - every refusal is reported, the test fails on it
        print(json.dumps({"error": f"{type(e).__name__}: {e}", "line": line}))
