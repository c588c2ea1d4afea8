#!/usr/bin/env bash
# run_live_chain_bench.sh BIN_DIR OUT_DIR [ioct-bench-live-chain options...]
# Runs the live chain benchmark and the chain's first half in CuPy (copy, processing, filters:
# cupy_live_chain.py) in one go on the same GPU, and prints ours beside CuPy's as ratios.
set -euo pipefail
[ $# -ge 2 ] || { echo "usage: run_live_chain_bench.sh BIN_DIR OUT_DIR [options]" >&2; exit 2; }
bin=$1
out=$2
shift 2
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
"$bin/ioct-bench-live-chain" --json "$out/live_chain.json" "$@"
echo
python3 "$here/cupy_live_chain.py" --json "$out/cupy_live_chain.json"
echo
python3 - "$out/live_chain.json" "$out/cupy_live_chain.json" <<'PY'
import json, sys
ours = json.load(open(sys.argv[1]))
cupy = json.load(open(sys.argv[2]))
rate, cupy_rate = ours["throughput"]["ascans_per_s"], cupy["ascans_per_s"]
filtered, rendered = ours["latency"]["filtered_ms"], ours["latency"]["rendered_ms"]
print("ioct beside CuPy (same run, same GPU; CuPy does the copy, processing and filters only):")
print(f"  A-scans/s: ioct's whole chain {rate / 1e6:.2f} M/s, CuPy's copy + processing + filters "
      f"{cupy_rate / 1e6:.2f} M/s: x{rate / cupy_rate:.2f}")
print(f"  per group p50: ioct published -> filtered {filtered['p50']:.3f} ms (-> frame rendered "
      f"{rendered['p50']:.3f}), CuPy copy -> filtered {cupy['latency_ms']['p50']:.3f} ms: "
      f"CuPy / ioct = {cupy['latency_ms']['p50'] / filtered['p50']:.2f}")
PY
