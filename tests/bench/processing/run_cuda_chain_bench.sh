#!/usr/bin/env bash
# run_cuda_chain_bench.sh BIN_DIR OUT_DIR [ioct-bench-cuda-chain options...]
# Runs the CUDA chain benchmark (ingest from a ring + processing) and the same chain in CuPy in
# one go on the same GPU, and prints our figures as ratios of CuPy's.
set -euo pipefail
[ $# -ge 2 ] || { echo "usage: run_cuda_chain_bench.sh BIN_DIR OUT_DIR [options]" >&2; exit 2; }
bin=$1
out=$2
shift 2
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
"$bin/ioct-bench-cuda-chain" --json "$out/cuda_chain.json" "$@"
echo
python3 "$here/cupy_chain.py" --json "$out/cupy_chain.json"
echo
python3 - "$out/cuda_chain.json" "$out/cupy_chain.json" <<'PY'
import json, sys
ours = {r["samples"]: r for r in json.load(open(sys.argv[1]))["results"]}
cupy = {r["samples"]: r for r in json.load(open(sys.argv[2]))["results"]}
print("ratios (ioct / CuPy, same run, same GPU):")
for samples in sorted(ours):
    if samples not in cupy:
        continue
    o, c = ours[samples], cupy[samples]
    print(f"  {samples} samples: ingest from the ring + processing "
          f"{o['pipeline_ascans_per_s'] / 1e6:.2f} M/s vs CuPy with H2D "
          f"{c['with_ingest_ascans_per_s'] / 1e6:.2f} M/s: x{o['pipeline_ascans_per_s'] / c['with_ingest_ascans_per_s']:.2f}; "
          f"processing only {o['compute_only_ascans_per_s'] / 1e6:.2f} vs "
          f"{c['compute_only_ascans_per_s'] / 1e6:.2f} M/s: "
          f"x{o['compute_only_ascans_per_s'] / c['compute_only_ascans_per_s']:.2f}")
PY
