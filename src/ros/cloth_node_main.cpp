// rosrun cloth_sim cloth_node [_scene:=flag] [_rows:=30] ...: see the README's parameter table.
#include "cloth_sim/ros/cloth_node.h"

#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "cloth_node");
  cloth_sim::ClothNode node{ros::NodeHandle(), ros::NodeHandle("~")};
  std::string error;
  if (!node.start(&error)) {
    ROS_FATAL("cloth_node: %s", error.c_str());
    return 1;
  }
  ros::spin();
  return 0;
}
