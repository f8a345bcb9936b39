# Set-up and everyday commands. Works on a fresh Debian 12 machine as root (or with sudo):
#   make run    install what is missing, build, run the main job
#   make test   install what is missing, build, run the test suite
# Other targets: deps, build, bench, asan-test, clean.

PACKAGES := build-essential cmake ninja-build pkg-config \
  libvulkan-dev mesa-vulkan-drivers vulkan-validationlayers vulkan-tools glslc \
  libsdl2-dev libeigen3-dev libtet1.5-dev libglm-dev libgtest-dev libgmock-dev libbenchmark-dev \
  libsuitesparse-dev libopenblas0-pthread libgdcm-dev libpng-dev zlib1g-dev libimgui-dev libstb-dev nlohmann-json3-dev gnuplot-nox xvfb xauth xdotool
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
JOBS ?= 2

.PHONY: deps build run test bench asan-test clean

deps:
	@missing=$$(for p in $(PACKAGES); do dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q 'install ok installed' || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "installing:" $$missing; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends $$missing; \
	fi

build: deps
	cmake --preset release
	cmake --build --preset release -j $(JOBS)

run: build
	./build/app/handson

test: build
	ctest --preset release

bench: build
	./build/app/handson bench $(BENCH_ARGS)

asan-test: deps
	cmake --preset asan
	cmake --build --preset asan -j $(JOBS)
	ctest --preset asan

clean:
	rm -rf build build-debug build-asan
