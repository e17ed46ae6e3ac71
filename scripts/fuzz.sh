#!/usr/bin/env bash
# Runs every fuzz target for SECONDS each (default 300) on seeds from tests/fuzz/corpus.
set -euo pipefail
build="$1"; seconds="${2:-300}"
cd "$(dirname "$0")/.."
for f in "$build"/tests/fuzz/fuzz_*; do
  name=$(basename "$f")
  corpus="tests/fuzz/corpus/${name#fuzz_}"
  work="$build/corpus/${name#fuzz_}"
  mkdir -p "$work"
  echo "== $name for ${seconds}s"
  "$f" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=4096 -max_len=65536 "$work" "$corpus" 2>&1 | tail -3
done
