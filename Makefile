# Entry points for people and CI. Each target installs what it needs first.
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=

.PHONY: deps configure build demo test clean

deps:
	@tools/install-deps.sh

configure: deps
	@cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS) >/dev/null

build: configure
	@cmake --build $(BUILD_DIR) -j $(JOBS)

# Renders the bundled default scene on the OpenCL device, unfolded and folded
# (xy), checks the two agree bit for bit and prints them side by side.
demo: build
	@mkdir -p out
	$(BUILD_DIR)/rayfold render --size 1280x720 --frames 5 --compare --fold xy \
	    -o out/demo.exr --png out/demo.png --stats out/demo.json

test: build
	@cd $(BUILD_DIR) && ctest --output-on-failure -j 2

clean:
	rm -rf $(BUILD_DIR) out
