# autocal — the commands a new user runs on a fresh Debian 12 machine.
#   make demo   deps + build + the main job (see README)
#   make test   deps + build + every gtest and rostest (scripts/run_tests.py: those off the wall
#               clock two at a time, then the rest alone); ends with "N passed, N failed"
#   make deps   installs the Debian packages (apt-get; prints the command when not root)
#   make build  Release build into build/, leaves build/devel/setup.bash
#   make bench  the benchmarks; updates BENCHMARKS.md's measured sections (scripts/bench.sh)
#   make robustness  the whole calibration in robot mode over drawn robots (scripts/robustness.py)

SHELL := /bin/bash
# A pyenv python3 may come first on PATH and lacks ROS's Python modules: use Debian's.
export PATH := /usr/bin:/bin:$(PATH)
export PYTHONNOUSERSITE := 1
# Make catkin (and rostest) find this package in the devel space and the source tree.
BUILD_DIR ?= build
JOBS ?= 2

DEBS := build-essential cmake catkin ros-base-dev libroscpp-dev python3-rostest librostest-dev \
  python3-roslaunch rosbash python3-rosbag librosbag-dev python3-rosnode python3-rostopic \
  libroslib-dev libros-rosgraph-msgs-dev libcv-bridge-dev libcamera-calibration-parsers-dev libtf2-ros-dev libsensor-msgs-dev \
  libgeometry-msgs-dev libnav-msgs-dev libstd-srvs-dev ros-message-generation \
  libvisualization-msgs-dev libdiagnostic-msgs-dev libdiagnostic-updater-dev python3-diagnostic-msgs \
  libbox2d-dev libapriltag-dev libopencv-dev libeigen3-dev libyaml-cpp-dev libgtest-dev \
  libbenchmark-dev opencv-doc python3-camera-calibration python3-image-geometry python3-opencv python3-cv-bridge \
  python3-yaml python3-numpy python3-nav-msgs python3-sensor-msgs python3-geometry-msgs python3-std-msgs

.PHONY: all deps build test demo bench robustness clean

all: build

deps:
	@missing=$$(for p in $(DEBS); do dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q '^install ok installed' || echo $$p; done); \
	if [ -z "$$missing" ]; then echo "deps: all Debian packages present"; exit 0; fi; \
	echo "deps: missing:" $$missing; \
	if [ "$$(id -u)" = 0 ]; then \
	  export DEBIAN_FRONTEND=noninteractive; \
	  apt-get update && apt-get install -y --no-install-recommends $$missing; \
	else \
	  echo "deps: not root; run:"; \
	  echo "  sudo apt-get update && sudo apt-get install -y --no-install-recommends $$missing"; \
	  exit 1; \
	fi

build: deps
	@# catkin caches the devel space's environment at configure time (catkin_generated/setup_cached.sh,
	@# which the tests run under) and only lists folders that exist then: without this one, a fresh
	@# clone's tests would run Python nodes with no path to this package's messages.
	@if [ -L $(BUILD_DIR)/devel ]; then rm $(BUILD_DIR)/devel; fi
	mkdir -p $(CURDIR)/$(BUILD_DIR)/devel/lib/python3/dist-packages
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3 \
	  -DCATKIN_ENABLE_TESTING=ON -DCATKIN_DEVEL_PREFIX=$(CURDIR)/$(BUILD_DIR)/devel
	@# rosrun and its tab completion skip everything under <package>/build/: ./bin, a link to the
	@# devel space's executables, is where they find the nodes and commands (and nothing else of
	@# the devel space: the tests' and benchmarks' binaries stay in build/test_bin and build/bench).
	ln -sfn $(BUILD_DIR)/devel/lib/autocal $(CURDIR)/bin
	cmake --build $(BUILD_DIR) -- -j$(JOBS)
	cmake --build $(BUILD_DIR) --target tests -- -j$(JOBS)

test: build
	@rm -rf $(BUILD_DIR)/test_results
	@source $(BUILD_DIR)/devel/setup.bash && \
	  ROS_PACKAGE_PATH=$(CURDIR):$$ROS_PACKAGE_PATH ROS_HOME=$(CURDIR)/$(BUILD_DIR)/ros_home \
	  cmake --build $(BUILD_DIR) --target tests -- -j$(JOBS) > $(BUILD_DIR)/run_tests.log 2>&1 && \
	  /usr/bin/python3 scripts/run_tests.py $(BUILD_DIR) $(BUILD_DIR)/run_tests.log --jobs $(JOBS); \
	  status=$$?; /usr/bin/python3 scripts/test_summary.py $(BUILD_DIR)/test_results $(BUILD_DIR)/run_tests.log $$status

demo: build
	@source $(BUILD_DIR)/devel/setup.bash && ROS_PACKAGE_PATH=$(CURDIR):$$ROS_PACKAGE_PATH \
	  ROS_HOME=$(CURDIR)/$(BUILD_DIR)/ros_home bash scripts/demo.sh

bench: build
	@source $(BUILD_DIR)/devel/setup.bash && ROS_PACKAGE_PATH=$(CURDIR):$$ROS_PACKAGE_PATH \
	  ROS_HOME=$(CURDIR)/$(BUILD_DIR)/ros_home bash scripts/bench.sh

# The whole calibration in robot mode over N drawn robots (not part of make test: about 3 minutes
# of wall time per robot and real-time factor); ROBUSTNESS_ARGS e.g. "--robots 4 --rtf 1".
robustness: build
	@source $(BUILD_DIR)/devel/setup.bash && ROS_PACKAGE_PATH=$(CURDIR):$$ROS_PACKAGE_PATH \
	  ROS_HOME=$(CURDIR)/$(BUILD_DIR)/ros_home /usr/bin/python3 scripts/robustness.py $(ROBUSTNESS_ARGS)

clean:
	rm -rf $(BUILD_DIR) devel bin
