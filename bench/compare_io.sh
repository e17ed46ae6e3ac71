#!/usr/bin/env bash
# Before/after, interleaved in one run on the same (shared, noisy) machine: this build's writer
# and reader benchmarks run against a baseline libtrellis (BASE: a directory holding the
# libtrellis.so.0.1 of the commit to compare with; the benchmarks use only the public API, so
# LD_LIBRARY_PATH swaps the library under the same benchmark code) and against this build's,
# ROUNDS times each. The two libraries must share the ABI the benchmarks use (GcodeSink gained
# object() in issue 23: an older library needs the benchmark built against its own headers).
# Usage: bench/compare_io.sh BASE [BUILD=build/release] [ROUNDS=3]
set -euo pipefail
base="$1"; build="${2:-build/release}"; rounds="${3:-3}"
for r in $(seq "$rounds"); do
  for b in bench_gcode_writer bench_gcode_reader; do
    LD_LIBRARY_PATH="$base" "$build/bench/$b" --benchmark_min_time=1 2>/dev/null |
      sed -n 's/^\(BM_[A-Za-z]*\).* bytes_per_second=\(.*\)/before \1 \2/p'
    "$build/bench/$b" --benchmark_min_time=1 2>/dev/null |
      sed -n 's/^\(BM_[A-Za-z]*\).* bytes_per_second=\(.*\)/after  \1 \2/p'
  done
done
