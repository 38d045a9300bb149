// rosrun cloth_sim cloth_node [_scene:=flag] [_rows:=30] ...: see the README's parameter table.
#include "cloth_sim/ros/cloth_node.h"
#include "cloth_sim/ros/master_watch.h"
#include "cloth_sim/ros/shutdown.h"

#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "cloth_node", ros::init_options::NoSigintHandler);
  cloth_sim::installShutdownSignals();
  ros::NodeHandle node_handle;
  // Declared before the node, so it still watches while the node is destroyed.
  cloth_sim::ShutdownWatchdog watchdog;
  cloth_sim::ClothNode node{node_handle, ros::NodeHandle("~")};
  std::string error;
  if (!node.start(&error)) {
    ROS_FATAL("cloth_node: %s", error.c_str());
    return 1;
  }
  cloth_sim::MasterWatch master_watch;
  ros::spin();
  return 0;
}
