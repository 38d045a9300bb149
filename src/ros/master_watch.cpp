#include "cloth_sim/ros/master_watch.h"

#include <ros/connection_manager.h>
#include <ros/master.h>
#include <ros/network.h>
#include <ros/service_manager.h>
#include <ros/xmlrpc_manager.h>

#include <vector>

namespace cloth_sim {

namespace {

using XmlRpc::XmlRpcValue;

/// The slave and master APIs answer [code, status message, value]; code 1 is success.
constexpr int kXmlRpcSuccess = 1;
constexpr int kXmlRpcAnswerSize = 3;
constexpr int kXmlRpcAnswerValue = 2;
/// getSystemState's value: [publishers, subscribers, services].
constexpr int kSystemStateParts = 3;
constexpr int kSystemStateServices = 2;
/// getBusInfo's row for one connection: [id, other end's XML-RPC URI, direction, transport, topic, ...].
constexpr int kBusInfoPeer = 1;
constexpr int kBusInfoDirection = 2;
constexpr int kBusInfoTopic = 4;
constexpr const char* kInbound = "i";

bool isArray(const XmlRpcValue& value) { return value.getType() == XmlRpcValue::TypeArray; }

/// Calls this process's own XML-RPC slave API: roscpp keeps its lists of publications, subscriptions and
/// connections private and answers them only there (the same answers rosnode info gets).
bool callOwnSlave(const std::string& method, const XmlRpcValue& args, XmlRpcValue* value) {
  std::string host;
  std::uint32_t port = 0;
  if (!ros::network::splitURI(ros::XMLRPCManager::instance()->getServerURI(), host, port)) return false;
  XmlRpc::XmlRpcClient client(host.c_str(), static_cast<int>(port), "/");
  XmlRpcValue answer;
  if (!client.execute(method.c_str(), args, answer) || client.isFault()) return false;
  if (!isArray(answer) || answer.size() != kXmlRpcAnswerSize || answer[0].getType() != XmlRpcValue::TypeInt ||
      static_cast<int>(answer[0]) != kXmlRpcSuccess) {
    return false;
  }
  *value = answer[kXmlRpcAnswerValue];
  return true;
}

/// Calls the master without waiting for it (roscpp's default retries for ever, which would hang the node).
bool callMaster(const std::string& method, const XmlRpcValue& args, XmlRpcValue* payload) {
  XmlRpcValue answer;
  return ros::master::execute(method, args, answer, *payload, false);
}

/// [caller_id, a, b, ...] as an XML-RPC argument list.
XmlRpcValue arguments(const std::vector<std::string>& values) {
  XmlRpcValue args;
  args.setSize(static_cast<int>(values.size()) + 1);
  args[0] = ros::this_node::getName();
  for (std::size_t i = 0; i < values.size(); ++i) args[static_cast<int>(i) + 1] = values[i];
  return args;
}

/// [[name, type], ...] from getPublications / getSubscriptions.
std::vector<std::pair<std::string, std::string>> topicsAndTypes(const XmlRpcValue& list) {
  std::vector<std::pair<std::string, std::string>> topics;
  if (!isArray(list)) return topics;
  for (int i = 0; i < list.size(); ++i) {
    const XmlRpcValue& entry = list[i];
    if (isArray(entry) && entry.size() == 2 && entry[0].getType() == XmlRpcValue::TypeString &&
        entry[1].getType() == XmlRpcValue::TypeString) {
      topics.emplace_back(static_cast<std::string>(entry[0]), static_cast<std::string>(entry[1]));
    }
  }
  return topics;
}

std::string joined(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& name : names) text += (text.empty() ? "" : ", ") + name;
  return text;
}

}  // namespace

MasterWatch::MasterWatch() : spinner_(1, &queue_) {
  rememberServices();
  ros::NodeHandle node_handle;
  node_handle.setCallbackQueue(&queue_);
  timer_ = node_handle.createWallTimer(ros::WallDuration(kCheckPeriod_s), &MasterWatch::check, this);
  spinner_.start();
}

MasterWatch::~MasterWatch() {
  spinner_.stop();
  timer_.stop();
}

void MasterWatch::check(const ros::WallTimerEvent&) {
  const std::string& master = ros::master::getURI();
  if (!ros::master::check()) {
    if (!master_lost_) {
      ROS_WARN("cloth_node: lost the ROS master at %s; simulating on, publishing on the connections already "
               "made, and registering again when a master answers there",
               master.c_str());
    }
    master_lost_ = true;
    return;
  }
  if (masterKnowsThisNode()) {
    if (master_lost_) {
      ROS_INFO("cloth_node: the ROS master at %s answers again and still knows this node", master.c_str());
    }
    master_lost_ = false;
    rememberServices();
    return;
  }
  master_lost_ = false;
  ROS_WARN("cloth_node: the ROS master at %s does not know this node (it was restarted): registering again",
           master.c_str());
  std::string report;
  if (registerAgain(&report)) {
    ROS_INFO("cloth_node: registered again with the ROS master at %s: %s", master.c_str(), report.c_str());
  } else {
    ROS_ERROR("cloth_node: registering again with the ROS master at %s failed: %s", master.c_str(), report.c_str());
  }
}

bool MasterWatch::masterKnowsThisNode() const {
  XmlRpcValue payload;
  return callMaster("lookupNode", arguments({ros::this_node::getName()}), &payload);
}

void MasterWatch::rememberServices() {
  XmlRpcValue state;
  if (!callMaster("getSystemState", arguments({}), &state) || !isArray(state) || state.size() != kSystemStateParts) return;
  const XmlRpcValue& services = state[kSystemStateServices];
  if (!isArray(services)) return;
  const std::string& self = ros::this_node::getName();
  for (int i = 0; i < services.size(); ++i) {
    const XmlRpcValue& entry = services[i];
    if (!isArray(entry) || entry.size() != 2 || !isArray(entry[1])) continue;
    for (int k = 0; k < entry[1].size(); ++k) {
      if (entry[1][k].getType() == XmlRpcValue::TypeString && static_cast<std::string>(entry[1][k]) == self) {
        services_.insert(static_cast<std::string>(entry[0]));
      }
    }
  }
}

bool MasterWatch::registerAgain(std::string* report) const {
  const std::string& own_uri = ros::XMLRPCManager::instance()->getServerURI();
  XmlRpcValue publications, subscriptions, connections;
  if (!callOwnSlave("getPublications", arguments({}), &publications) ||
      !callOwnSlave("getSubscriptions", arguments({}), &subscriptions) ||
      !callOwnSlave("getBusInfo", arguments({}), &connections)) {
    *report = "this process's own XML-RPC server did not list its topics";
    return false;
  }
  std::vector<std::string> failed;
  int published = 0;
  for (const auto& topic : topicsAndTypes(publications)) {
    XmlRpcValue payload;
    if (callMaster("registerPublisher", arguments({topic.first, topic.second, own_uri}), &payload)) {
      ++published;
    } else {
      failed.push_back(topic.first);
    }
  }
  int subscribed = 0;
  for (const auto& topic : topicsAndTypes(subscriptions)) {
    XmlRpcValue publishers;
    if (!callMaster("registerSubscriber", arguments({topic.first, topic.second, own_uri}), &publishers) ||
        !isArray(publishers)) {
      failed.push_back(topic.first);
      continue;
    }
    ++subscribed;
    // The master lists the publishers it knows; those this node is already connected to stay in the list,
    // since a publisher list is taken as complete and a publisher left out would be disconnected.
    for (int i = 0; i < connections.size(); ++i) {
      const XmlRpcValue& row = connections[i];
      if (isArray(row) && row.size() > kBusInfoTopic && row[kBusInfoDirection].getType() == XmlRpcValue::TypeString &&
          static_cast<std::string>(row[kBusInfoDirection]) == kInbound &&
          row[kBusInfoTopic].getType() == XmlRpcValue::TypeString &&
          static_cast<std::string>(row[kBusInfoTopic]) == topic.first &&
          row[kBusInfoPeer].getType() == XmlRpcValue::TypeString) {
        publishers[publishers.size()] = static_cast<std::string>(row[kBusInfoPeer]);
      }
    }
    XmlRpcValue update = arguments({topic.first});
    update[2] = publishers;
    XmlRpcValue ignored;
    if (publishers.size() > 0 && !callOwnSlave("publisherUpdate", update, &ignored)) failed.push_back(topic.first);
  }
  const std::string service_uri = "rosrpc://" + ros::network::getHost() + ":" +
                                  std::to_string(ros::ConnectionManager::instance()->getTCPPort());
  int served = 0;
  for (const std::string& service : services_) {
    if (!ros::ServiceManager::instance()->lookupServicePublication(service)) continue;  // unadvertised since
    XmlRpcValue payload;
    if (callMaster("registerService", arguments({service, service_uri, own_uri}), &payload)) {
      ++served;
    } else {
      failed.push_back(service);
    }
  }
  *report = std::to_string(published) + " publications, " + std::to_string(subscribed) + " subscriptions, " +
            std::to_string(served) + " services";
  if (!failed.empty()) *report += "; failed: " + joined(failed);
  return failed.empty();
}

}  // namespace cloth_sim
