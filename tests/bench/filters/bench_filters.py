#!/usr/bin/env python3
"""Volume filters on the GPU: ours (ioct-bench-filters) against cupyx.scipy.ndimage on the same
volume in the same run.

Makes one u8 volume (default 128 x 512 x 688, seeded speckle-like noise), writes it to --out,
runs ioct-bench-filters on it (our kernels, timed with CUDA events, checked against the CPU
filter), then times cupyx median_filter(size=3) and gaussian_filter (5x5 in each B-scan: sigma 0
along B-scans, truncate so the radius is 2) on the same bytes, and compares the results:
  - median: cupyx mode 'nearest' repeats the edge voxel as ours does; the two must be identical.
  - median + Gaussian: ours is fixed point, within 1 u8 step of the exact Gaussian; compared with
    cupyx's Gaussian computed in float32 and rounded to nearest, differences of 1 are expected,
    larger ones are not.
Prints a table (ms, ratio to ours) and writes bench_filters.json beside the volume.

    python3 tests/bench/filters/bench_filters.py --bench build/release/bin/ioct-bench-filters --out /tmp/f
"""
import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

try:
    import cupy as cp
    from cupyx.scipy import ndimage
except ImportError as error:  # the GPU machine has CuPy; say clearly when this one does not
    sys.exit(f"bench_filters.py: CuPy is needed ({error})")


def time_gpu(function, warmup, reps):
    """Median, min and max milliseconds of `function` over `reps` runs, CUDA events around each."""
    for _ in range(warmup):
        function()
    cp.cuda.get_current_stream().synchronize()
    times = []
    for _ in range(reps):
        start, stop = cp.cuda.Event(), cp.cuda.Event()
        start.record()
        function()
        stop.record()
        stop.synchronize()
        times.append(cp.cuda.get_elapsed_time(start, stop))
    times.sort()
    return {"median_ms": times[len(times) // 2], "min_ms": times[0], "max_ms": times[-1]}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bench", required=True, help="path of ioct-bench-filters")
    parser.add_argument("--out", required=True, help="directory for the volume and results")
    parser.add_argument("--dims", default="128,512,688", help="B-scans,A-scans,depth")
    parser.add_argument("--sigma", type=float, default=1.0)
    parser.add_argument("--reps", type=int, default=50)
    parser.add_argument("--warmup", type=int, default=5)
    args = parser.parse_args()

    dims = tuple(int(x) for x in args.dims.split(","))
    os.makedirs(args.out, exist_ok=True)
    rng = np.random.default_rng(2016)
    # Speckle-like: Rayleigh-distributed amplitude on a depth ramp, so the volume has structure
    # and ties like a real one, not only uniform noise.
    ramp = np.linspace(20, 160, dims[2], dtype=np.float32)
    volume = np.clip(rng.rayleigh(1.0, size=dims).astype(np.float32) * ramp, 0, 255).astype(np.uint8)
    volume_path = os.path.join(args.out, "volume.u8")
    volume.tofile(volume_path)

    ours_json = os.path.join(args.out, "ours.json")
    median_path = os.path.join(args.out, "ours_median.u8")
    filtered_path = os.path.join(args.out, "ours_filtered.u8")
    command = [args.bench, "--dims", args.dims, "--input", volume_path, "--sigma", str(args.sigma),
               "--reps", str(args.reps), "--warmup", str(args.warmup),
               "--output-median", median_path, "--output-filtered", filtered_path,
               "--json", ours_json]
    print("$ " + " ".join(command), flush=True)
    ours_status = subprocess.run(command).returncode
    if ours_status != 0:
        print(f"ioct-bench-filters exited {ours_status}", flush=True)
    with open(ours_json) as f:
        ours = json.load(f)

    device = cp.cuda.runtime.getDeviceProperties(cp.cuda.Device().id)
    print(f"\ncupyx {cp.__version__} on {device['name'].decode()}, same volume", flush=True)
    gpu_volume = cp.asarray(volume)
    radius = 2
    truncate = (radius + 0.49) / args.sigma  # int(truncate * sigma + 0.5) == 2
    gauss_sigma = (0.0, args.sigma, args.sigma)

    def median():
        return ndimage.median_filter(gpu_volume, size=3, mode="nearest")

    def gaussian(x):
        return ndimage.gaussian_filter(x, sigma=gauss_sigma, mode="nearest", truncate=truncate)

    cupyx = {
        "device copy of the volume": time_gpu(lambda: gpu_volume.copy(), args.warmup, args.reps),
        "median_filter(size=3)": time_gpu(median, args.warmup, args.reps),
        "gaussian_filter 5x5 per B-scan": time_gpu(lambda: gaussian(gpu_volume), args.warmup,
                                                   args.reps),
        "median + gaussian": time_gpu(lambda: gaussian(median()), args.warmup, args.reps),
    }
    for name, t in cupyx.items():
        print(f"  {name:44s} {t['median_ms']:9.4f} ms  [{t['min_ms']:.4f}, {t['max_ms']:.4f}]")

    cupyx_median = cp.asnumpy(median())
    # The Gaussian in float32, rounded to nearest: the exact filter ours must be within 1 step of.
    cupyx_filtered = cp.asnumpy(cp.rint(gaussian(cp.asarray(cupyx_median, dtype=cp.float32))))
    ours_median = np.fromfile(median_path, dtype=np.uint8).reshape(dims)
    ours_filtered = np.fromfile(filtered_path, dtype=np.uint8).reshape(dims)
    median_mismatch = int(np.count_nonzero(ours_median != cupyx_median))
    difference = np.abs(ours_filtered.astype(np.int16) - cupyx_filtered.astype(np.int16))
    comparison = {
        "median_voxels_differing": median_mismatch,
        "filtered_max_abs_difference": int(difference.max()),
        "filtered_fraction_differing": float(np.count_nonzero(difference) / difference.size),
    }
    ours_by_name = {t["name"]: t for t in ours["timings"]}
    combined = next(t for n, t in ours_by_name.items() if n.startswith("median + Gaussian"))
    best_median = next(t for n, t in ours_by_name.items()
                       if n == "median " + ours["best_median"])
    gaussian_alone = ours_by_name[ours["best_gaussian"]]
    print("\nratios (cupyx / ours, same volume, same run):")
    print(f"  median:            {cupyx['median_filter(size=3)']['median_ms']:.4f} / "
          f"{best_median['median_ms']:.4f} ms = "
          f"{cupyx['median_filter(size=3)']['median_ms'] / best_median['median_ms']:.1f}x")
    print(f"  Gaussian:          {cupyx['gaussian_filter 5x5 per B-scan']['median_ms']:.4f} / "
          f"{gaussian_alone['median_ms']:.4f} ms = "
          f"{cupyx['gaussian_filter 5x5 per B-scan']['median_ms'] / gaussian_alone['median_ms']:.1f}x")
    print(f"  median + Gaussian: {cupyx['median + gaussian']['median_ms']:.4f} / "
          f"{combined['median_ms']:.4f} ms = "
          f"{cupyx['median + gaussian']['median_ms'] / combined['median_ms']:.1f}x "
          f"(target for ours: 0.15 ms)")
    print(f"  results: median voxels differing from cupyx: {median_mismatch}; median + Gaussian: "
          f"max |difference| {comparison['filtered_max_abs_difference']}, "
          f"{100 * comparison['filtered_fraction_differing']:.3f}% of voxels differ")

    result = {"date_utc": time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime()),
              "dims": dims, "sigma": args.sigma, "ours": ours, "cupyx": cupyx,
              "cupy_version": cp.__version__, "comparison": comparison}
    with open(os.path.join(args.out, "bench_filters.json"), "w") as f:
        json.dump(result, f, indent=2)
    return 0 if ours_status == 0 and median_mismatch == 0 and difference.max() <= 1 else 1


if __name__ == "__main__":
    sys.exit(main())
