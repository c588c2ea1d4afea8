#!/usr/bin/env python3
"""The live chain's first half written in CuPy: the anchor ioct-bench-live-chain is compared with.

Per group of the default geometry (16 B-scans x 512 A-scans x 1376 u16 samples, 128 B-scans per
volume): the pinned host -> device copy, the processing of cupy_chain.py (background, Hann window,
real FFT, dB to u8), the group's B-scans written into a device volume of 128 x 512 x 688, then
cupyx.scipy.ndimage median_filter(size=3) and the 5x5 Gaussian per B-scan over the B-scans the
group changes (its own and one on each side, each read with its neighbours), written back into
the filtered volume. CuPy has no segmentation or renderer, so the anchor is processing + filters:
ioct's chain does that and more (segmentation, the renderer's update, a render per group).
Measured two ways with CUDA events:
  latency      one group at a time, each waited for (copy -> filtered), ms per group
  throughput   groups back to back on one stream, A-scans/s
Prints both and, with --json, writes them for run_live_chain_bench.sh.
"""
import argparse
import json
import os
import sys

import numpy as np

try:
    import cupy as cp
    import cupyx
    from cupyx.scipy import ndimage
except ImportError as error:  # the GPU machine has CuPy; say clearly when this one does not
    sys.exit(f"cupy_live_chain.py: CuPy is needed ({error})")

# One home for the CuPy processing chain: the processing benchmark's.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "processing"))
from cupy_chain import make_chain  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=1376)
    parser.add_argument("--ascans", type=int, default=512, help="A-scans per B-scan")
    parser.add_argument("--group-bscans", type=int, default=16)
    parser.add_argument("--volume-bscans", type=int, default=128)
    parser.add_argument("--sigma", type=float, default=1.0, help="the Gaussian's, in voxels")
    parser.add_argument("--groups", type=int, default=400)
    parser.add_argument("--json")
    args = parser.parse_args()
    if args.volume_bscans % args.group_bscans != 0:
        sys.exit("cupy_live_chain.py: --volume-bscans must be a multiple of --group-bscans")

    depth = args.samples // 2
    group_ascans = args.group_bscans * args.ascans
    groups_per_volume = args.volume_bscans // args.group_bscans
    chain = make_chain(args.samples)
    truncate = (2 + 0.49) / args.sigma  # a radius of 2: the 5x5 kernel
    sigma = (0.0, args.sigma, args.sigma)

    rng = np.random.default_rng(1)
    host = cupyx.empty_pinned((group_ascans, args.samples), dtype=np.uint16)
    host[...] = rng.integers(0, 4096, size=host.shape, dtype=np.uint16)
    raw = cp.empty(host.shape, dtype=cp.uint16)
    volume = cp.zeros((args.volume_bscans, args.ascans, depth), dtype=cp.uint8)
    filtered = cp.zeros_like(volume)

    def one_group(index):
        first = (index % groups_per_volume) * args.group_bscans
        raw.set(host)  # pinned host -> device on the current stream
        volume[first:first + args.group_bscans] = chain(raw).reshape(
            args.group_bscans, args.ascans, depth)
        # The median of B-scan b reads b - 1 .. b + 1, so the group changes one B-scan more on
        # each side; those are filtered from their own neighbours, as ioct's filter does.
        out_first = max(first - 1, 0)
        out_end = min(first + args.group_bscans + 1, args.volume_bscans)
        in_first = max(out_first - 1, 0)
        in_end = min(out_end + 1, args.volume_bscans)
        median = ndimage.median_filter(volume[in_first:in_end], size=3, mode="nearest")
        smooth = ndimage.gaussian_filter(median, sigma=sigma, mode="nearest", truncate=truncate)
        filtered[out_first:out_end] = smooth[out_first - in_first:out_end - in_first]

    for index in range(2 * groups_per_volume):  # warm-up: plans, kernels compiled
        one_group(index)
    cp.cuda.get_current_stream().synchronize()

    latencies = []
    for index in range(args.groups):
        start, stop = cp.cuda.Event(), cp.cuda.Event()
        start.record()
        one_group(index)
        stop.record()
        stop.synchronize()
        latencies.append(cp.cuda.get_elapsed_time(start, stop))
    latencies.sort()
    quantile = lambda q: latencies[min(len(latencies) - 1, int(q * len(latencies)))]  # noqa: E731

    start, stop = cp.cuda.Event(), cp.cuda.Event()
    start.record()
    for index in range(args.groups):
        one_group(index)
    stop.record()
    stop.synchronize()
    rate = args.groups * group_ascans / (cp.cuda.get_elapsed_time(start, stop) * 1e-3)

    device = cp.cuda.runtime.getDeviceProperties(cp.cuda.runtime.getDevice())
    report = {"benchmark": "cupy_live_chain", "cupy": cp.__version__,
              "gpu": device["name"].decode(), "groups": args.groups,
              "latency_ms": {"p50": quantile(0.5), "p99": quantile(0.99), "max": latencies[-1]},
              "ascans_per_s": rate}
    print(f"cupy_live_chain: CuPy {cp.__version__} on {report['gpu']}: copy + processing + "
          f"filters per group p50 {quantile(0.5):.3f} ms, p99 {quantile(0.99):.3f} ms; "
          f"back to back {rate / 1e6:.2f} M A-scans/s")
    if args.json:
        with open(args.json, "w") as out:
            json.dump(report, out, indent=2)


if __name__ == "__main__":
    main()
