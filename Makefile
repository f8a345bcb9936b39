# Set-up and everyday commands. Works on a fresh Debian 12 machine as root (or with sudo):
#   make run    install what is missing, build, run the main job
#   make test   install what is missing, build, run the test suite
# Other targets: deps, build, bench, gpu-check (a GPU machine's one command), asan-test (the suite
# under ASan+UBSan, clang), fuzz (FUZZ_SECONDS per fuzzer, default 60), core-test (sim/ and
# interaction/ alone: no Vulkan, SDL2 or GDCM needed), clean. WERROR=ON makes every compiler warning
# an error (CI sets it).

PACKAGES := build-essential cmake ninja-build pkg-config \
  libvulkan-dev mesa-vulkan-drivers vulkan-validationlayers vulkan-tools glslc \
  libsdl2-dev libeigen3-dev libtet1.5-dev libglm-dev libgtest-dev libgmock-dev libbenchmark-dev \
  libsuitesparse-dev libteem-dev libinsighttoolkit5-dev libopenblas0-pthread libgdcm-dev libpng-dev zlib1g-dev libimgui-dev libstb-dev nlohmann-json3-dev gnuplot-nox xvfb xauth xdotool
# What sim/ and interaction/ alone need (make core-test).
CORE_PACKAGES := build-essential cmake ninja-build libeigen3-dev libtet1.5-dev libglm-dev libgtest-dev libsuitesparse-dev libopenblas0-pthread
FUZZ_PACKAGES := clang libclang-rt-14-dev
FUZZ_SECONDS ?= 60
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
JOBS ?= 2
WERROR ?= OFF

.PHONY: deps fuzz-deps build run test bench gpu-check asan-test fuzz core-test clean external-data

deps:
	@missing=$$(for p in $(PACKAGES); do dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q 'install ok installed' || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "installing:" $$missing; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends $$missing; \
	fi

build: deps
	cmake --preset release -DHANDSON_WERROR=$(WERROR)
	cmake --build --preset release -j $(JOBS)

# The app alone: `make run` builds the handson target and what it needs (its shaders and libraries),
# not the test binaries, so the first picture comes sooner on a fresh machine.
run: deps
	cmake --preset release -DHANDSON_WERROR=$(WERROR)
	cmake --build --preset release -j $(JOBS) --target handson
	./build/app/handson

test: build external-data
	ctest --preset release

# Other projects' test files (nibabel's NIfTI, pydicom's DICOM, ITK's MetaImage), from Debian's packages, unpacked
# into build/external-data without installing them (their Python dependencies are not needed);
# tests/app/io/test_external_files.cpp compares our readers with the values nibabel and pydicom give,
# and with ITK's example images' raw data.
# Without network the download is skipped and those tests say so.
EXTERNAL_DATA := build/external-data
EXTERNAL_DEBS := python3-nibabel python3-pydicom insighttoolkit5-examples
ITK_EXAMPLE_DATA := usr/share/doc/insighttoolkit5-examples/examples/Data
external-data:
	@if [ ! -f $(EXTERNAL_DATA)/usr/lib/python3/dist-packages/pydicom/data/test_files/CT_small.dcm ] || \
	    [ ! -f $(EXTERNAL_DATA)/$(ITK_EXAMPLE_DATA)/CorpusCallosumMeanShape.mha ]; then \
	  mkdir -p $(EXTERNAL_DATA)/debs && cd $(EXTERNAL_DATA)/debs && \
	  { apt-get download $(EXTERNAL_DEBS) >/dev/null 2>&1 || \
	    { $(SUDO) apt-get update -qq && apt-get download $(EXTERNAL_DEBS) >/dev/null 2>&1; }; } && \
	  for d in *.deb; do dpkg -x $$d ..; done && echo "external test data: nibabel's, pydicom's and ITK's example files unpacked" || \
	  echo "external test data could not be downloaded: those tests will be skipped"; \
	fi

bench: build
	./build/app/handson bench $(BENCH_ARGS)

# On a machine with a Vulkan GPU: the GPU tests on it, the benchmark suite (--quick) and a live drag,
# one report in gpu-check-out/gpu-check.md (.ci/gpu-check; it refuses without a GPU).
gpu-check: build
	.ci/gpu-check --no-build $(GPU_CHECK_ARGS)

# The sanitizer build (clang, AddressSanitizer + UndefinedBehaviorSanitizer, libFuzzer coverage):
# the whole test suite under the sanitizers, and the fuzzers.
fuzz-deps: deps
	@missing=$$(for p in $(FUZZ_PACKAGES); do dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q 'install ok installed' || echo $$p; done); \
	if [ -n "$$missing" ]; then $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends $$missing; fi

LSAN := LSAN_OPTIONS=suppressions=$(CURDIR)/tests/lsan.supp

asan-test: fuzz-deps external-data
	cmake --preset asan -DHANDSON_WERROR=$(WERROR)
	cmake --build --preset asan -j $(JOBS)
	$(LSAN) ctest --preset asan

# libFuzzer: the NIfTI, NRRD and MetaImage readers, the DICOM reader and the session-script parser (tests/fuzz), each run
# for FUZZ_SECONDS over a working copy of its seed corpus (new inputs stay in build-asan/corpus), the
# five at once (each its own process; logs in build-asan/findings/<kind>.log, printed at the end);
# a finding stops that fuzzer with the crashing input written to build-asan/findings/ and fails the target.
fuzz: fuzz-deps
	cmake --preset asan -DHANDSON_WERROR=$(WERROR)
	cmake --build --preset fuzz
	mkdir -p build-asan/findings
	set -e; for t in nifti nrrd metaimage dicom script; do \
	  mkdir -p build-asan/corpus/$$t; cp -n tests/fuzz/corpus/$$t/* build-asan/corpus/$$t/; \
	  if [ $$t = script ]; then cp -n assets/gestures/*.json build-asan/corpus/$$t/; fi; \
	done; \
	echo "fuzzing nifti, nrrd, metaimage, dicom and script for $(FUZZ_SECONDS) s each, at once"; \
	pids=""; for t in nifti nrrd metaimage dicom script; do \
	  $(LSAN) ./build-asan/tests/fuzz/fuzz_$$t build-asan/corpus/$$t -max_total_time=$(FUZZ_SECONDS) -timeout=20 -rss_limit_mb=3072 \
	    -malloc_limit_mb=2048 -artifact_prefix=build-asan/findings/$$t- -print_final_stats=1 > build-asan/findings/$$t.log 2>&1 & pids="$$pids $$!"; \
	done; \
	status=0; for p in $$pids; do wait $$p || status=1; done; \
	for t in nifti nrrd metaimage dicom script; do echo "== fuzz_$$t"; grep -E "^(stat::|Done|INFO: Loaded|==[0-9]+==|SUMMARY|artifact_prefix|Test unit written)" build-asan/findings/$$t.log || true; done; \
	if [ $$status != 0 ]; then for t in nifti nrrd metaimage dicom script; do echo "== fuzz_$$t (last lines)"; tail -40 build-asan/findings/$$t.log; done; fi; \
	exit $$status

# sim/ and interaction/ with their tests, on a machine that has none of Vulkan, SDL2, GDCM or glslc
# (build-core; installs only CORE_PACKAGES).
core-test:
	@missing=$$(for p in $(CORE_PACKAGES); do dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q 'install ok installed' || echo $$p; done); \
	if [ -n "$$missing" ]; then $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends $$missing; fi
	cmake -S . -B build-core -G Ninja -DCMAKE_BUILD_TYPE=Release -DHANDSON_CORE_ONLY=ON -DHANDSON_WERROR=$(WERROR)
	cmake --build build-core -j $(JOBS)
	ctest --test-dir build-core -j $(JOBS) --output-on-failure

clean:
	rm -rf build build-debug build-asan build-core
