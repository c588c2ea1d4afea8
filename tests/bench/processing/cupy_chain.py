#!/usr/bin/env python3
"""The OCT chain written in CuPy: the anchor ioct-bench-cuda-chain is compared with.

u16 spectra of one group (8192 A-scans at the default geometry) -> mean-spectrum background
removal -> Hann window -> real FFT (cuFFT through cupy.fft) -> 10 log10 |X|^2 -> u8 over 0..40 dB,
keeping the N/2 positive depths. Measured two ways, each over many groups with CUDA events:
  compute only   the spectra already on the GPU (the design's 14.7 M A-scans/s anchor)
  with ingest    each group first copied from pinned host memory, on the same stream
Prints A-scans/s and, with --json, writes them for run_cuda_chain_bench.sh.
"""
import argparse
import json

import cupy as cp
import cupyx
import numpy as np


def make_chain(samples):
    window = cp.asarray(np.hanning(samples).astype(np.float32))
    norm_db = 20.0 * np.log10(2.0 / float(np.hanning(samples).sum()))
    db_min, db_max = 0.0, 40.0
    scale = np.float32(255.0 / (db_max - db_min))
    offset = np.float32(norm_db - db_min)

    def chain(raw):
        x = raw.astype(cp.float32)
        x -= x.mean(axis=0)
        x *= window
        bins = cp.fft.rfft(x, axis=1)[:, : samples // 2]
        power = bins.real * bins.real + bins.imag * bins.imag
        level = (10.0 * cp.log10(power) + offset) * scale
        return cp.clip(level + 0.5, 0, 255).astype(cp.uint8)

    return chain


def ascans_per_second(run, ascans, groups):
    for _ in range(5):
        run()
    start, stop = cp.cuda.Event(), cp.cuda.Event()
    start.record()
    for _ in range(groups):
        run()
    stop.record()
    stop.synchronize()
    return groups * ascans / (cp.cuda.get_elapsed_time(start, stop) * 1e-3)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, nargs="+", default=[1376, 2048])
    parser.add_argument("--ascans", type=int, default=512 * 16, help="A-scans per group")
    parser.add_argument("--groups", type=int, default=200)
    parser.add_argument("--json")
    args = parser.parse_args()

    device = cp.cuda.runtime.getDeviceProperties(cp.cuda.runtime.getDevice())
    report = {"benchmark": "cupy_chain", "cupy": cp.__version__,
              "gpu": device["name"].decode(), "results": []}
    print(f"cupy_chain: CuPy {cp.__version__} on {report['gpu']}")
    rng = np.random.default_rng(1)
    for samples in args.samples:
        chain = make_chain(samples)
        host = cupyx.empty_pinned((args.ascans, samples), dtype=np.uint16)
        host[...] = rng.integers(0, 4096, size=host.shape, dtype=np.uint16)
        raw = cp.asarray(host)
        compute = ascans_per_second(lambda: chain(raw), args.ascans, args.groups)

        def with_ingest():
            raw.set(host)  # pinned host -> device on the current stream
            chain(raw)

        ingest = ascans_per_second(with_ingest, args.ascans, args.groups)
        print(f"  {samples} samples: compute only {compute / 1e6:.2f} M A-scans/s, "
              f"with H2D from pinned memory {ingest / 1e6:.2f} M A-scans/s")
        report["results"].append({"samples": samples, "compute_only_ascans_per_s": compute,
                                  "with_ingest_ascans_per_s": ingest})
    if args.json:
        with open(args.json, "w") as out:
            json.dump(report, out, indent=2)


if __name__ == "__main__":
    main()
