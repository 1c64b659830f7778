# Entry points for people and CI. Each target installs what it needs first.
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=

FUZZ_SECONDS ?= 60

.PHONY: deps configure build demo test python-env test-asan fuzz bench clean

deps:
	@tools/scripts/install-deps.sh

configure: deps
	@cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release $(PYTHON_FLAGS) $(CMAKE_FLAGS) >/dev/null

build: configure
	@cmake --build $(BUILD_DIR) -j $(JOBS)

# Renders the bundled default scene on the OpenCL device, unfolded and folded
# (xy), checks the two agree bit for bit and prints them side by side.
demo: build
	@mkdir -p out
	$(BUILD_DIR)/rayfold render --size 1280x720 --frames 5 --compare --fold xy \
	    -o out/demo.exr --png out/demo.png --stats out/demo.json

# The tests build the Python module too, in a venv under the build folder.
test: PYTHON_FLAGS = -DRAYFOLD_PYTHON=ON -DPython_EXECUTABLE=$(CURDIR)/$(BUILD_DIR)/venv/bin/python
test: python-env build
	@cd $(BUILD_DIR) && ctest --output-on-failure -j 2

python-env: deps
	@tools/scripts/python-env.sh $(BUILD_DIR)/venv

# Fold tables, speed against accuracy with Embree, from Python against
# Mitsuba 3 and Open3D, the G-buffer's channels and the dataset loop against
# Mitsuba and Blender's Cycles, and charts for the bundled scene and every scene in
# ../shared/scenes, into out/bench/. Long (about 75 minutes on 2 cores);
# BENCH_ARGS="--views 3 --frames 3" shortens it. Open3D's wheel needs libusb.
BENCH_ARGS ?=
bench: PYTHON_FLAGS = -DRAYFOLD_PYTHON=ON -DPython_EXECUTABLE=$(CURDIR)/$(BUILD_DIR)/venv/bin/python
bench: python-env build
	@tools/scripts/install-deps.sh python3-matplotlib libusb-1.0-0 blender python3-numpy
	@tools/scripts/python-env.sh $(BUILD_DIR)/venv --peers
	PYTHONPATH=$(CURDIR)/$(BUILD_DIR)/python BENCH_PYTHON=$(CURDIR)/$(BUILD_DIR)/venv/bin/python \
	    tools/bench/bench_all.sh $(BENCH_ARGS)

# The whole suite under AddressSanitizer and UndefinedBehaviorSanitizer.
# Leaks inside the OpenCL runtime (PoCL, LLVM) are suppressed; ours are not.
# use_tls=0: LSan's scan of the dynamic TLS blocks PoCL's dlopen'ed kernel
# libraries leave behind crashed its tracer ("Tracer caught signal 11") on
# some scenes; glibc's loader allocations it then misses are suppressed.
# use_sigaltstack=0: the thread that opens the OpenCL device gets an
# alternate signal stack from malloc (PoCL calls LLVM's RemoveFileOnSignal),
# and ASan, which unmaps a finished thread's alternate stack as if it had
# mapped it, stopped every test that opened the device ("failed to
# deallocate 0x12000 bytes"; this project's code of 2026-12-05 start too).
test-asan: deps
	@cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DRAYFOLD_SANITIZE=ON >/dev/null
	@cmake --build build-asan -j $(JOBS)
	@cd build-asan && ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:use_sigaltstack=0 \
	    LSAN_OPTIONS=suppressions=$(CURDIR)/tests/lsan.supp:print_suppressions=0:use_tls=0 \
	    UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 ctest --output-on-failure -j 2

# Fuzzes loading, building and tracing for FUZZ_SECONDS (default 60) from the
# seed corpus in tests/fuzz/corpus, checking rayfold's invariants on every
# accepted input (tests/fuzz/fuzz_scene.cpp); findings land in build-fuzz/.
# Leaks inside the OpenCL runtime are suppressed as in test-asan.
fuzz:
	@tools/scripts/install-deps.sh clang libclang-rt-14-dev
	@CC=clang CXX=clang++ cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DRAYFOLD_FUZZ=ON \
	    -DBUILD_TESTING=OFF >/dev/null
	@cmake --build build-fuzz --target fuzz_scene -j $(JOBS)
	@mkdir -p build-fuzz/corpus build-fuzz/findings
	LSAN_OPTIONS=suppressions=$(CURDIR)/tests/lsan.supp:print_suppressions=0:use_tls=0 \
	    build-fuzz/fuzz_scene build-fuzz/corpus tests/fuzz/corpus -max_total_time=$(FUZZ_SECONDS) \
	    -max_len=65536 -rss_limit_mb=4096 -timeout=30 -artifact_prefix=build-fuzz/findings/ -print_final_stats=1

clean:
	rm -rf $(BUILD_DIR) build-asan build-fuzz out
