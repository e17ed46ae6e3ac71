# Trellis: two commands for users (`make demo`, `make test`), a few more for developers.
PRESET ?= release
BUILD  := build/$(PRESET)
JOBS   ?= $(shell nproc)
# `make test` ends with the sanitizer stage (see sanitize below); `make test SANITIZE=0` skips it.
# Its ASan + cheap-UBSan build at -O1 costs about 1.6 x a release compile (src/slice/pbf.cpp: 11 s
# against 6.1 s; full UBSan at -O2 -g was 7.5 x): ~17 CPU-min cold, its tests ~100 s.
SANITIZE ?= 1

.PHONY: deps configure build demo test sanitize python bench bench-viewer compare fuzz asan format clean

deps:
	@bash scripts/install-deps.sh

configure: deps
	@test -f $(BUILD)/build.ninja || cmake --preset $(PRESET) >/dev/null

build: configure
	@cmake --build $(BUILD) -j $(JOBS)

demo: build
	@bash scripts/demo.sh $(BUILD)/apps/trellis/trellis

test: build
	@cd $(BUILD) && ctest --output-on-failure -j $(JOBS)
ifeq ($(PRESET)$(SANITIZE),release1)
	@$(MAKE) --no-print-directory sanitize
endif

# The sanitizer stage (`make sanitize`; `make test` runs it last, SANITIZE=0 skips it; issue 47
# item 6): an ASan + cheap-UBSan build (preset asan) runs what reads untrusted input: every
# reader's unit tests (core, toolpath, lattice, machine, field, cli), the planners, the print
# check and the renderer (plan, analysis, render), the committed fuzz corpora replayed through
# every fuzz target, and streaming. The hostile suite runs in the release ctest only (under ASan
# it would add 10-15 min to CI). ASan frames are 2-3 x larger, so the deep-graph tests (1,000
# nested 3MF nodes) get a 64 MiB stack here. `make asan` runs the whole suite under the
# sanitizers (not in CI: too long).
SANITIZE_TARGETS := trellis_cli test_core test_toolpath test_lattice test_machine test_field \
                    test_cli test_plan test_analysis test_render test_stream $(addprefix replay_,$(notdir $(basename $(wildcard tests/fuzz/corpus/*))))
SANITIZE_TESTS := ^(core|toolpath|lattice|machine|field|cli|plan|analysis|render|stream|fuzz_corpus_.*)$$
sanitize: deps
	@test -f build/asan/build.ninja || cmake --preset asan >/dev/null
	@cmake --build build/asan -j $(JOBS) --target $(SANITIZE_TARGETS)
	@cd build/asan && { ulimit -s 65536 2>/dev/null || echo "sanitize: stack limit stays at $$(ulimit -s) KiB"; } && \
	  ctest --output-on-failure -j $(JOBS) -R '$(SANITIZE_TESTS)'

python: build
	@bash scripts/install-python.sh $(BUILD)

bench: build
	@for b in $(BUILD)/bench/bench_*; do echo "== $$b"; $$b --benchmark_min_time=1; done

# The viewer with a ~100 MB G-code file in headless Chromium (docs/viewer.md).
bench-viewer: build
	@node bench/viewer_bench.mjs $(BUILD)/apps/trellis/trellis $(BUILD)/viewer/node_modules out/bench_viewer

compare: build
	@bash scripts/control_slicer.sh $(BUILD)/apps/trellis/trellis out/control

asan:
	@$(MAKE) test PRESET=asan

fuzz: deps
	@test -f build/fuzz/build.ninja || cmake --preset fuzz >/dev/null
	@cmake --build build/fuzz -j $(JOBS)
	@bash scripts/fuzz.sh build/fuzz $${FUZZ_SECONDS:-300}

format:
	@git ls-files '*.cpp' '*.hpp' '*.h' '*.cc' | xargs clang-format -i

clean:
	@rm -rf build out
