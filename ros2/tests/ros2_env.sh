# Source me: the environment in which rclpy finds the venv's ROS 2 and our message packages.
_cliff_ros2="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
. "$_cliff_ros2/.venv/bin/activate"
ws="$_cliff_ros2/.ws/install"
sp=lib/python3.11/site-packages
export PYTHONPATH="$ws/people_msgs/$sp:$ws/cliff_msgs/$sp:$ws/autoware_perception_msgs/$sp${PYTHONPATH:+:$PYTHONPATH}"
export LD_LIBRARY_PATH="$ws/people_msgs/lib:$ws/cliff_msgs/lib:$ws/autoware_perception_msgs/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export AMENT_PREFIX_PATH="$ws/people_msgs:$ws/cliff_msgs:$ws/autoware_perception_msgs:$VIRTUAL_ENV"
export RMW_IMPLEMENTATION=rmw_fastrtps_cpp
