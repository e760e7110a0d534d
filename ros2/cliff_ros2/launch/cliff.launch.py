"""cliffd and cliff-ros2 together: the daemon serves the map given as the `map` launch
argument under the name `map_name`, the node predicts through it with the parameters
file `params_file` (default: the installed config/cliff.yaml, every parameter at its
default) and draws that map on cliff/map_markers.

    ros2 launch cliff_ros2 cliff.launch.py map:=/path/to/cliffmap.csv
    ros2 launch cliff_ros2 cliff.launch.py map:=site.cliff map_name:=site params_file:=my.yaml
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackagePrefix, FindPackageShare


def generate_launch_description():
    map_file = LaunchConfiguration("map")
    map_name = LaunchConfiguration("map_name")
    params_file = LaunchConfiguration("params_file")
    return LaunchDescription([
        DeclareLaunchArgument(
            "map", description="the map file cliffd serves (.csv, .cliff or a time-of-day set)"),
        DeclareLaunchArgument(
            "map_name", default_value="site", description="the map's name at cliffd"),
        DeclareLaunchArgument(
            "params_file",
            default_value=PathJoinSubstitution([FindPackageShare("cliff_ros2"), "config", "cliff.yaml"]),
            description="the node's parameters file"),
        # cliffd is no ROS node: started as a plain process (it takes no --ros-args)
        ExecuteProcess(
            name="cliffd",
            cmd=[PathJoinSubstitution([FindPackagePrefix("cliff_ros2"), "lib", "cliff_ros2", "cliffd"]),
                 "--map", [map_name, "=", map_file]],
            output="screen"),
        Node(
            package="cliff_ros2", executable="cliff-ros2", name="cliff_ros2", output="screen",
            parameters=[params_file, {"map_file": "", "daemon_map": map_name, "map_markers_file": map_file}]),
    ])
