# cloth_sim developer entry points, for a fresh Debian 12 machine (as root) and for a working one.
#
#   make deps    install the Debian packages below that are missing (apt-get runs only if one is)
#   make build   catkin_make in a private workspace outside the repo: $(WS) (override: make build WS=...)
#   make test    build, run every gtest and rostest, catkin_lint, and a downstream build of
#                examples/cloth_sim_example; print the failing cases and "N passed, N failed"
#   make demo    build, run cloth.launch headless for DEMO_SECONDS s recording a bag, render the last mesh
#                to a PNG and print the mesh publish rate (make demo SCENE=flag)
#   make bench   build, then time cloth_sim against Bullet's soft-body cloth at 20, 64, 128 and 256
#                (scripts/bench.py): markdown tables on stdout, the raw results (one JSON document) in
#                .build/bench_results.json
#                (make bench BENCH_ARGS=--quick, or BENCH_ARGS="--sizes 20,64 --frames 20")
#   make load    build, then flood a cloth_node (its own master, the hanging scene at 64x64) with ~wind at
#                10 kHz and ~grasp at 1 kHz for 30 s (scripts/load.py): rates sent, received and dropped,
#                ~state and ~mesh rates, frame period percentiles, memory growth (make load
#                LOAD_ARGS="--seconds 5 --rows 20 --cols 20")
#   make rates   build, then run every built-in scene at 64x64 and 128x128 (its own defaults otherwise) in a
#                cloth_node on its own master and measure ~state (and ~mesh) with the C++ cloth_topic_rate:
#                a markdown table of Hz, step cost, real-time factor and diagnostics (scripts/rates.py;
#                make rates RATES_ARGS="--scenes flag,drape --sizes 128 --seconds 10")
#   make accuracy  build, then measure cost against error of every integrator and substep count on hanging, flag
#                and ball at 20-80 per side, stability maps and each scene's terms (scripts/accuracy.py, about
#                20-25 minutes): writes doc/ACCURACY.md and doc/images/accuracy_*.png, raw outputs in .build/accuracy
#                (make accuracy ACCURACY_ARGS=--reuse rewrites the page from them without running again: each
#                output made with the same cloth_bench arguments, recorded beside it; --quick keeps to
#                .build/accuracy/quick)
#   make validate  build, then run the textile tests of issue 17 (cantilever against the heavy elastica, the
#                drape per preset and resolution, the hanging sheet's strain; scripts/validate.py, about 25
#                minutes): writes doc/VALIDATION.md and doc/images/validation_*.png, raw outputs in
#                .build/validate (make validate VALIDATE_ARGS=--reuse rewrites the page without running again)
#   make pictures  record every scene (or SCENES="flag ball") and render it in rviz under Xvfb into
#                doc/images/rviz_<scene>.png, plus the demo's picture of SCENE (drape unless SCENE= says
#                otherwise) as doc/images/demo_<SCENE>.png
#   make fuzz    build the libFuzzer targets of test/fuzz with clang (outside catkin) and run each for
#                FUZZ_SECONDS (60) s: executions, execs/s, coverage, findings; non-zero on any finding.
#                Corpora and findings stay in .build/fuzz (FUZZ_DIR)
#   make sanitize  the core gtests and the node under ASan + UBSan in their own workspace ($(WS)-sanitize),
#                running the gtests and the rostests in SANITIZE_ROSTESTS; non-zero on any report.
#                Not part of make test (a second full build)
#   make clean   remove the private workspaces (also the sanitize one), the demo outputs and the fuzz build
#
# Cloned into an existing catkin workspace's src/ instead? Then catkin_make there as usual: nothing in
# the package assumes the private workspace (or pass WS=/path/to/that/workspace to these targets).

SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
.DEFAULT_GOAL := build
.PHONY: deps build test demo bench accuracy validate load pictures clean help fuzz sanitize sanitize-run rates

# Debian 12's own ROS 1 packages (no /opt/ros); this is the one list of what the project needs.
DEB_PACKAGES := build-essential cmake pkg-config \
  ros-core-dev libroscpp-dev libtf2-ros-dev libtf2-geometry-msgs-dev ros-visualization-msgs \
  libvisualization-msgs-dev libgeometry-msgs-dev libstd-srvs-dev libstd-msgs-dev librostest-dev \
  python3-rostest python3-roslaunch libdynamic-reconfigure-config-init-mutex-dev \
  python3-dynamic-reconfigure libdiagnostic-updater-dev librosbag-dev python3-rosbag rosbash catkin \
  python3-catkin-pkg libeigen3-dev libstb-dev libyaml-cpp-dev python3-matplotlib python3-numpy xvfb \
  libgtest-dev topic-tools python3-rospy rviz \
  librviz-dev libtopic-tools-dev \
  python3-std-msgs python3-geometry-msgs python3-visualization-msgs python3-diagnostic-msgs \
  python3-rosgraph-msgs python3-std-srvs python3-tf2-msgs \
  libbullet-dev catkin-lint \
  libsensor-msgs-dev python3-sensor-msgs libdepth-image-proc-dev libnodeletlib-tools \
  libinteractive-markers-dev liburdf-dev ros-robot-state-publisher
# libbullet-dev above is for cloth_bench's --bullet comparison only (not a run or build dependency of
# the package: package.xml does not list it).
# Only `make pictures` needs these (rviz screenshots under Xvfb with ImageMagick's import).
PICTURE_PACKAGES := imagemagick
# Only `make fuzz` needs these: clang with libFuzzer and the sanitizer runtimes, llvm-symbolizer for
# readable stacks, gencpp for the message headers the conversions target includes.
FUZZ_PACKAGES := clang libclang-rt-14-dev llvm-14 python3-gencpp

REPO := $(patsubst %/,%,$(dir $(abspath $(lastword $(MAKEFILE_LIST)))))
# One workspace per clone (keyed by the clone's absolute path), outside the repo: rosrun searches a
# package's source folder following symlinks, so a workspace inside the repo would be found as copies.
WS_ROOT ?= $(HOME)/.cache/cloth_sim
WS ?= $(WS_ROOT)/ws-$(shell printf '%s' '$(REPO)' | sha1sum | cut -c1-10)
override WS := $(patsubst %/,%,$(abspath $(WS)))
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
SCENE ?= drape
DEMO_SECONDS ?= 10
DEMO_DIR ?= $(REPO)/.build/demo

# Debian's ROS tools and catkin's generators are /usr/bin/python3 programs; a python3 found earlier on
# PATH (pyenv, a virtualenv) lacks the ROS modules. So /usr/bin comes first, and CMake is told too.
export PATH := /usr/bin:/bin:/usr/sbin:/sbin:$(PATH)
CATKIN_MAKE := catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCMAKE_BUILD_TYPE=Release
# Logs and the ROS home (rospack cache, roslaunch/rostest logs) stay in the workspace, not in ~/.ros.
export ROS_HOME := $(WS)/ros_home
export ROS_LOG_DIR := $(WS)/ros_home/log
# rostest starts its own master on a random port; nodes must reach it even where the hostname does not
# resolve (containers, CI).
ifeq ($(strip $(ROS_HOSTNAME)$(ROS_IP)),)
export ROS_HOSTNAME := localhost
endif
# The sub-makes that catkin_make runs get their -j from the command line below, not from ours.
unexport MAKEFLAGS
# A shell that sourced this workspace's own devel/setup.bash must not leak it into catkin's configure
# step: catkin caches only the difference from the environment it finds, so the tests' environment would
# lose ROS_PACKAGE_PATH ("Package [cloth_sim] does not exist"). Other (parent) workspaces stay.
empty :=
space := $(empty) $(empty)
without = $(subst $(space),:,$(strip $(filter-out $(2),$(subst :, ,$(1)))))
export CMAKE_PREFIX_PATH := $(call without,$(CMAKE_PREFIX_PATH),$(WS)/devel)
export ROS_PACKAGE_PATH := $(call without,$(ROS_PACKAGE_PATH),$(WS)/src $(WS)/src/cloth_sim)

help:
	@sed -n '1,/^$$/p' $(lastword $(MAKEFILE_LIST)) | sed 's/^# \{0,1\}//'

deps:
	@installed=" $$({ dpkg-query -W -f='$${db:Status-Abbrev} $${Package}\n' $(DEB_PACKAGES) 2>/dev/null || true; } \
	  | awk '$$1 == "ii" {printf "%s ", $$2}')"; \
	missing=""; for p in $(DEB_PACKAGES); do \
	  case "$$installed" in *" $$p "*) ;; *) missing="$$missing $$p";; esac; \
	done; \
	if [ -z "$$missing" ]; then echo "==> deps: all $(words $(DEB_PACKAGES)) Debian packages installed"; exit 0; fi; \
	echo "==> deps: installing$$missing"; \
	sudo=""; if [ "$$(id -u)" != 0 ]; then \
	  if command -v sudo >/dev/null; then sudo="sudo"; else \
	    echo "deps: not root and no sudo; as root run: apt-get install$$missing" >&2; exit 1; fi; fi; \
	export DEBIAN_FRONTEND=noninteractive; \
	$$sudo apt-get update -q; \
	$$sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -q$$missing

build: deps
	@mkdir -p $(WS)/src
	@case "$(REPO)/" in \
	  "$(WS)/src/"*) ;; \
	  *) link=$(WS)/src/cloth_sim; \
	     if [ -e "$$link" ] && [ ! -L "$$link" ]; then \
	       echo "build: $$link exists and is not a link to this repo; use another WS=" >&2; exit 1; fi; \
	     [ "$$(readlink "$$link" 2>/dev/null)" = "$(REPO)" ] || ln -sfn "$(REPO)" "$$link";; \
	esac
	@echo "==> build: catkin_make in $(WS) (-j$(JOBS))"
	@cd $(WS) && $(CATKIN_MAKE) -j$(JOBS) -l$(JOBS) 2>&1 | $(FILTER_CMAKE)
	@echo "==> build: done; to use it: source $(WS)/devel/setup.bash"

# catkin_make repeats CMake's whole configure log on every run; keep the lines that matter.
FILTER_CMAKE := { grep --line-buffered -v -E '^make\[[0-9]+\]: (Entering|Leaving) directory|^-- (Using|Found|Looking|Detecting|Check|Performing|Call |This workspace|The C|catkin [0-9]|BUILD_SHARED_LIBS|Configuring|Generating|  |~~)|^(Base path|Source space|Build space|Devel space|Install space|\#\#\#\#)' || true; }

test: build
	@echo "==> test: building the test executables"
	@cd $(WS) && $(CATKIN_MAKE) -j$(JOBS) -l$(JOBS) tests 2>&1 | $(FILTER_CMAKE)
	@echo "==> test: running cloth_sim's gtests and rostests, one at a time"
	@rm -rf $(WS)/build/test_results/cloth_sim
	@rc=0; (cd $(WS) && $(CATKIN_MAKE) -j1 run_tests_cloth_sim 2>&1 | $(FILTER_CMAKE)) || rc=$$?; \
	if [ $$rc != 0 ]; then echo "test: catkin_make run_tests_cloth_sim exited with $$rc"; fi; \
	/usr/bin/python3 $(REPO)/scripts/catkin_lint_junit.py $(REPO) $(WS)/build/test_results/cloth_sim/lint-catkin_lint.xml \
	  || rc=1; \
	bash $(REPO)/scripts/build_example.sh $(WS)/devel $(WS)-example \
	  $(WS)/build/test_results/cloth_sim/example-downstream.xml || rc=1; \
	/usr/bin/python3 $(REPO)/scripts/test_summary.py $(WS)/build/test_results/cloth_sim \
	  --ctest-file $(WS)/build/cloth_sim/CTestTestfile.cmake || rc=1; \
	exit $$rc

demo: build
	@bash $(REPO)/scripts/demo.sh $(WS) $(SCENE) $(DEMO_SECONDS) $(DEMO_DIR)

BENCH_ARGS ?=
bench: build
	@/usr/bin/python3 $(REPO)/scripts/bench.py --bench $(WS)/devel/lib/cloth_sim/cloth_bench \
	  --out $(REPO)/.build/bench_results.json $(BENCH_ARGS)

LOAD_ARGS ?=
load: build
	@bash -c 'source $(WS)/devel/setup.bash && exec /usr/bin/python3 $(REPO)/scripts/load.py $(LOAD_ARGS)'

RATES_ARGS ?=
rates: build
	@bash -c 'source $(WS)/devel/setup.bash && exec /usr/bin/python3 $(REPO)/scripts/rates.py $(RATES_ARGS)'

ACCURACY_ARGS ?=
accuracy: build
	@/usr/bin/python3 $(REPO)/scripts/accuracy.py --bench $(WS)/devel/lib/cloth_sim/cloth_bench --repo $(REPO) \
	  $(ACCURACY_ARGS)

validate: build
	@/usr/bin/python3 $(REPO)/scripts/validate.py --bench $(WS)/devel/lib/cloth_sim/cloth_bench --repo $(REPO) \
	  $(VALIDATE_ARGS)

pictures: demo
	@$(MAKE) --no-print-directory deps DEB_PACKAGES="$(PICTURE_PACKAGES)"
	@cp $(DEMO_DIR)/$(SCENE).png $(REPO)/doc/images/demo_$(SCENE).png
	@bash -c 'source $(WS)/devel/setup.bash && exec bash $(REPO)/scripts/make_pictures.sh $(REPO)/doc/images $(SCENES)'

# ---- make fuzz: the libFuzzer targets of test/fuzz, FUZZ_SECONDS each ---------------------------------
FUZZ_SECONDS ?= 60
FUZZ_DIR ?= $(REPO)/.build/fuzz
fuzz:
	@$(MAKE) --no-print-directory deps DEB_PACKAGES="$(FUZZ_PACKAGES)"
	@echo "==> fuzz: building the targets in $(FUZZ_DIR)/build (clang, -j$(JOBS))"
	@CC=clang CXX=clang++ cmake -S $(REPO)/test/fuzz -B $(FUZZ_DIR)/build -DCMAKE_BUILD_TYPE=RelWithDebInfo \
	  2>&1 | $(FILTER_CMAKE)
	@cmake --build $(FUZZ_DIR)/build -j$(JOBS) 2>&1 | { grep -v -E '^\[ *[0-9]+%\]|^g?make\[[0-9]+\]: (Entering|Leaving)' || true; }
	@bash $(REPO)/test/fuzz/run_fuzzers.sh $(FUZZ_DIR) $(FUZZ_SECONDS)

# ---- make sanitize: the core gtests and the node under AddressSanitizer + UndefinedBehaviorSanitizer ----
# A workspace of its own (instrumented objects must not mix with the normal build), built by the same
# build logic with the flags appended to catkin_make's CMake arguments. Every report is written to a
# log file (a node's report would otherwise vanish into rostest's log) and any log fails the target.
SANITIZE_WS ?= $(WS)-sanitize
SANITIZE_FLAGS := -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
SANITIZE_ROSTESTS ?= services.test interaction.test
sanitize:
	@$(MAKE) --no-print-directory sanitize-run WS=$(SANITIZE_WS) JOBS=$(JOBS) \
	  SANITIZE_ROSTESTS="$(SANITIZE_ROSTESTS)"

sanitize-run: CATKIN_MAKE += '-DCMAKE_CXX_FLAGS=$(SANITIZE_FLAGS)' '-DCMAKE_EXE_LINKER_FLAGS=$(SANITIZE_FLAGS)' \
  '-DCMAKE_SHARED_LINKER_FLAGS=$(SANITIZE_FLAGS)'
sanitize-run: build
	@echo "==> sanitize: building the test executables in $(WS)"
	@cd $(WS) && $(CATKIN_MAKE) -j$(JOBS) -l$(JOBS) tests 2>&1 | $(FILTER_CMAKE)
	@logs=$(WS)/sanitizer_logs; rm -rf $$logs; mkdir -p $$logs; \
	export ASAN_OPTIONS="log_path=$$logs/asan:detect_leaks=1:detect_stack_use_after_return=1"; \
	export UBSAN_OPTIONS="log_path=$$logs/ubsan:print_stacktrace=1:halt_on_error=1"; \
	export LSAN_OPTIONS="suppressions=$(REPO)/test/fuzz/lsan.supp"; \
	set +u; source $(WS)/devel/setup.bash; set -u; rc=0; \
	echo "==> sanitize: core gtests"; \
	$(WS)/devel/lib/cloth_sim/cloth_sim_core_tests || rc=1; \
	echo "==> sanitize: conversions gtests"; \
	$(WS)/devel/lib/cloth_sim/cloth_sim_conversions_tests || rc=1; \
	for t in $(SANITIZE_ROSTESTS); do \
	  echo "==> sanitize: rostest cloth_sim $$t"; \
	  rostest cloth_sim $$t > $$logs/rostest-$${t%.test}.out 2>&1 || { rc=1; tail -30 $$logs/rostest-$${t%.test}.out; }; \
	  grep -E '^ \* (RESULT|TESTS|ERRORS|FAILURES):' $$logs/rostest-$${t%.test}.out || true; \
	done; \
	reports="$$(find $$logs -name 'asan*' -o -name 'ubsan*') $$(grep -l -E 'runtime error:|ERROR: (Address|Leak)Sanitizer' $$logs/*.out 2>/dev/null || true)"; \
	reports=$$(echo $$reports); \
	if [ -n "$$reports" ]; then echo "sanitize: sanitizer reports:"; for f in $$reports; do echo "--- $$f"; head -40 "$$f"; done; rc=1; fi; \
	if [ $$rc = 0 ]; then echo "==> sanitize: clean (no ASan/UBSan/LSan report, all tests passed)"; fi; \
	exit $$rc

clean:
	rm -rf $(WS) $(WS)-example $(SANITIZE_WS) $(DEMO_DIR) $(FUZZ_DIR)
