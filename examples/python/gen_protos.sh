#!/usr/bin/env bash
# Generates the Python protobuf classes of interface_yaml/proto (Goby3's frontseat messages and
# ours) with grpcio-tools, into examples/python/gen/ or the directory given as $1.
#   pip install -r examples/python/requirements.txt && examples/python/gen_protos.sh
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
proto="$(cd "$here/../../interface_yaml/proto" && pwd)"
out="${1:-$here/gen}"
mkdir -p "$out"
mapfile -t files < <(cd "$proto" && find . -name '*.proto' | sed 's|^\./||' | sort)
python3 -m grpc_tools.protoc -I "$proto" --python_out="$out" "${files[@]}"
echo "generated ${#files[@]} proto files into $out"
