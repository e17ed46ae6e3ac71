# Trellis: two commands for users (`make demo`, `make test`), a few more for developers.
PRESET ?= release
BUILD  := build/$(PRESET)
JOBS   ?= $(shell nproc)

.PHONY: deps configure build demo test python bench bench-viewer compare fuzz asan format clean

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
	@clang-format -i $$(git ls-files '*.cpp' '*.hpp')

clean:
	@rm -rf build out
