#!/usr/bin/env bash
# run_replay_speed_bench.sh BIN_DIR RECORDING OUT_DIR [SPEEDS] [-- ioct-rt options...]
# Replays an ioct-record recording through ioct-rt at rising --replay-speed into
# `ioct-gpu --backend cuda` and prints, per speed, the A-scans/s the GPU process kept up with and
# the groups it lost. The ring never waits for a reader, so the fastest speed with 0 drops is the
# chain's sustained rate on this recording. SPEEDS: comma-separated multiples (default
# 1,2,4,8,16); the ioct-rt options after `--` must give the recording's geometry (e.g. --config
# of the run), and its A-scan rate, which the recording does not keep.
set -euo pipefail
usage="usage: run_replay_speed_bench.sh BIN_DIR RECORDING OUT_DIR [SPEEDS] [-- ioct-rt options]"
[ $# -ge 3 ] || { echo "$usage" >&2; exit 2; }
bin=$1
recording=$2
out=$3
shift 3
speeds=1,2,4,8,16
if [ $# -gt 0 ] && [ "$1" != "--" ]; then speeds=$1; shift; fi
[ $# -gt 0 ] && [ "$1" = "--" ] && shift
seconds=${IOCT_BENCH_SECONDS:-20}
backend=${IOCT_BENCH_BACKEND:-cuda}  # cpu: to try the script on a machine without a GPU
[ -f "$recording" ] || { echo "run_replay_speed_bench.sh: no recording $recording" >&2; exit 2; }
mkdir -p "$out"
ring="ioct-replay-bench-$$"
printf '%-7s %17s %17s %10s %10s %8s %8s\n' speed "offered A-scans/s" "kept up A-scans/s" published processed lapped behind
for speed in ${speeds//,/ }; do
  dir="$out/speed-$speed"
  mkdir -p "$dir"
  "$bin/ioct-rt" --ring "$ring" "$@" --replay "$recording" --replay-speed "$speed" \
    --seconds "$seconds" --summary "$dir/rt.json" >"$dir/rt.log" 2>&1 &
  rt_pid=$!
  "$bin/ioct-gpu" --backend "$backend" --ring "$ring" --out "$dir" --wait 30 \
    --exit-when-producer-gone >"$dir/gpu.log" 2>&1 || echo "speed $speed: ioct-gpu failed, see $dir/gpu.log" >&2
  wait "$rt_pid" || echo "speed $speed: ioct-rt failed, see $dir/rt.log" >&2
  python3 - "$speed" "$dir/summary.json" "$dir/rt.json" <<'PY'
import json, sys
speed, gpu_path, rt_path = sys.argv[1:]
try:
    gpu = json.load(open(gpu_path))
    rt = json.load(open(rt_path))
except (OSError, ValueError) as e:
    print(f"{speed:<8} no figures: {e}")
    sys.exit(0)
geometry = gpu["geometry"] or {}
ascans_per_group = geometry.get("ascans_per_bscan", 0) * geometry.get("bscans_per_group", 0)
published = rt["groups_published"]
offered = published * ascans_per_group / rt["seconds"] if rt["seconds"] > 0 else 0.0
g = gpu["groups"]
print(f"{speed:<7} {offered:17.0f} {gpu['ascans_per_second']:17.0f} {published:10d} "
      f"{g['processed']:10d} {g['dropped_lapped']:8d} {g['dropped_behind']:8d}")
PY
done
