#!/usr/bin/env bash
# Regenerates the image gallery of docs/rendering.md: a simulated retina (epiretinal membrane,
# forceps) and a simulated anterior segment, made with ioct-sim-record and ioct-process, and the
# real Spectralis B-scan of tests/data, rendered with ioct-render in every mode.
#   tools/make-render-gallery.sh BIN_DIR OUT_DIR [--backend cpu|cuda|auto] [--threads N]
# BIN_DIR holds ioct-sim-record, ioct-process and ioct-render (e.g. build/release/bin);
# OUT_DIR receives the PNGs (docs/images/render for the committed gallery). The CPU reference
# is the default backend, so the images do not depend on the machine's GPU.
set -euo pipefail

usage() { sed -n 2,7p "$0"; }
[ $# -ge 2 ] || { usage >&2; exit 2; }
bin=$1
out=$2
shift 2
backend=cpu
threads=$(nproc 2>/dev/null || echo 2)
while [ $# -gt 0 ]; do
  case "$1" in
    --backend) backend=${2:?--backend needs a value}; shift 2 ;;
    --threads) threads=${2:?--threads needs a value}; shift 2 ;;
    -h|--help) usage; exit 0 ;;
    *) echo "make-render-gallery: unknown option '$1' (try --help)" >&2; exit 2 ;;
  esac
done
for tool in ioct-sim-record ioct-process ioct-render; do
  [ -x "$bin/$tool" ] || { echo "make-render-gallery: no $bin/$tool (build it first)" >&2; exit 2; }
done
root=$(cd "$(dirname "$0")/.." && pwd)
vol="$root/tests/data/spectralis_circle_valid.vol"
[ -f "$vol" ] || { echo "make-render-gallery: missing $vol" >&2; exit 2; }
if ! [[ $threads =~ ^[1-9][0-9]*$ ]]; then
  echo "make-render-gallery: --threads must be a whole number >= 1, got '$threads'" >&2
  exit 2
fi
process_threads=$((threads > 16 ? 16 : threads))  # ioct-process takes 1 to 16

mkdir -p "$out"
work=$(mktemp -d "${TMPDIR:-/tmp}/ioct-render-gallery.XXXXXX")
trap 'rm -rf "$work"' EXIT

# quietly COMMAND...: runs it with its output kept aside, shown only when it fails.
quietly() {
  if ! "$@" > "$work/log" 2>&1; then
    cat "$work/log" >&2
    echo "make-render-gallery: failed: $*" >&2
    exit 1
  fi
}

# render NAME INPUT MODE [ioct-render options...]: one image, written as OUT_DIR/NAME.png.
render() {
  local name=$1 input=$2 mode=$3
  shift 3
  quietly "$bin/ioct-render" "$input" --out "$work/png" --prefix "$name." --mode "$mode" \
    --backend "$backend" --threads "$threads" "$@"
  cp "$work/png/$name.$mode.png" "$out/$name.png"
  echo "  $out/$name.png"
}

# --- Simulated retina: one volume of 128 B-scans x 512 A-scans x 688 px (6 x 6 x 3.86 mm), an
# epiretinal membrane and open forceps above it. Processed twice: as acquired (Viehland Fig. 4a)
# and with the median 3x3x3 + Gaussian 5x5 filters (Fig. 4b on), as the live system renders it.
echo "simulated retina"
quietly "$bin/ioct-sim-record" --out "$work/retina" --groups 8 --preset retina --membrane \
  --tool forceps:x=0.3,y=0.0,depth=0.5,yaw=150,pitch=10,open=30 --seed 1
spacing=0.005605,0.01174,0.04724  # depth, A-scan, B-scan (mm): 6 mm over 511 and 127 steps
quietly "$bin/ioct-process" "$work/retina" --out "$work/retina-raw.nrrd" --spacing-mm "$spacing" \
  --threads "$process_threads"
quietly "$bin/ioct-process" "$work/retina" --out "$work/retina.nrrd" --spacing-mm "$spacing" \
  --filter median-gauss --threads "$process_threads"
sim="$work/retina.nrrd"
size=(--width 512 --height 384)
view=(--azimuth 30 --elevation 25 --zoom 1.4)

# Viehland et al. 2016, Fig. 4: (a) basic ray casting of the volume as acquired, (b) of the
# filtered volume, then the enhancement steps added one by one: (c) edges, (d) features,
# (e) depth cues, (f) Phong, i.e. every step.
render sim-basic-unfiltered "$work/retina-raw.nrrd" basic "${size[@]}" "${view[@]}" --layers none
render sim-basic "$sim" basic "${size[@]}" "${view[@]}"
render sim-enhanced-edges "$sim" enhanced "${size[@]}" "${view[@]}" --no-feature \
  --no-depth-cues --no-phong
render sim-enhanced-features "$sim" enhanced "${size[@]}" "${view[@]}" --no-depth-cues --no-phong
render sim-enhanced-depth-cues "$sim" enhanced "${size[@]}" "${view[@]}" --no-phong
render sim-enhanced "$sim" enhanced "${size[@]}" "${view[@]}"
render sim-enhanced-stereo "$sim" enhanced --width 384 --height 288 "${view[@]}" --stereo
# Weiss et al. 2019: layer-aware DVR in lightness only (their Fig. 4 A1), coloured without
# shadows (A2), with N_s = 20 (A3) and N_s = 200 (A4); the axial colorization baseline without
# and with Phong (B2, B3); the LA-MIP composite (Fig. 1 right).
render sim-layer-aware-lightness "$sim" layer-aware "${size[@]}" "${view[@]}" --shadow-steps 20 \
  --no-colorize
render sim-layer-aware-ns0 "$sim" layer-aware "${size[@]}" "${view[@]}" --shadow-steps 0
render sim-layer-aware-ns20 "$sim" layer-aware "${size[@]}" "${view[@]}" --shadow-steps 20
render sim-layer-aware-ns200 "$sim" layer-aware "${size[@]}" "${view[@]}" --shadow-steps 200
render sim-axial-colorization "$sim" axial-colorization "${size[@]}" "${view[@]}"
render sim-axial-colorization-phong "$sim" axial-colorization "${size[@]}" "${view[@]}" \
  --axial-phong
render sim-la-mip "$sim" la-mip "${size[@]}"
render sim-bscan "$sim" bscan "${size[@]}"
render sim-en-face "$sim" en-face "${size[@]}"

# --- Simulated anterior segment (Viehland Fig. 5): 64 B-scans x 256 A-scans x 1376 px over
# 10 x 10 x 7.7 mm, the whole chamber (2752 samples per A-scan); no retina, so no RPE.
echo "simulated anterior segment"
quietly "$bin/ioct-sim-record" --out "$work/anterior" --groups 4 --preset anterior --samples 2752 \
  --ascans 256 --bscans-per-volume 64 --seed 1
quietly "$bin/ioct-process" "$work/anterior" --out "$work/anterior.nrrd" \
  --spacing-mm 0.005605,0.03922,0.15873 --filter median-gauss --threads "$process_threads"
ant="$work/anterior.nrrd"
ant_view=(--azimuth 30 --elevation 15 --zoom 1.4 --layers none)
render anterior-basic "$ant" basic "${size[@]}" "${ant_view[@]}"
render anterior-enhanced-retina-preset "$ant" enhanced "${size[@]}" "${ant_view[@]}"
render anterior-enhanced-anterior-preset "$ant" enhanced "${size[@]}" "${ant_view[@]}" \
  --preset anterior
render anterior-bscan "$ant" bscan "${size[@]}" --layers none

# --- The real Spectralis circle B-scan (768 A-scans x 496 px, its own ILM and BM lines). One
# B-scan has no B-scan spacing: the volume modes render it as a slab 3 mm thick.
echo "Spectralis .vol"
slab=(--bscan-spacing-um 3000)
vol_view=(--azimuth 20 --elevation 35 --zoom 1.3)
render vol-basic "$vol" basic "${size[@]}" "${vol_view[@]}" "${slab[@]}"
render vol-enhanced "$vol" enhanced "${size[@]}" "${vol_view[@]}" "${slab[@]}"
render vol-layer-aware-ns20 "$vol" layer-aware "${size[@]}" "${vol_view[@]}" "${slab[@]}" \
  --shadow-steps 20
render vol-layer-aware-ns200 "$vol" layer-aware "${size[@]}" "${vol_view[@]}" "${slab[@]}" \
  --shadow-steps 200
render vol-axial-colorization "$vol" axial-colorization "${size[@]}" "${vol_view[@]}" "${slab[@]}"
render vol-la-mip "$vol" la-mip "${size[@]}" "${slab[@]}"
render vol-bscan "$vol" bscan "${size[@]}"

echo "make-render-gallery: $(find "$out" -maxdepth 1 -name '*.png' | wc -l) images in $out"
