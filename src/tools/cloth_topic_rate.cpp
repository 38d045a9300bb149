// cloth_topic_rate: how fast topics really arrive at a C++ subscriber, as one JSON line.
//
//   rosrun cloth_sim cloth_topic_rate [--seconds 10] [--wait 30] [--skip 1] [--queue 1] TOPIC...
//
// Subscribes to every TOPIC as a topic_tools::ShapeShifter (any type, never deserialised: the bytes are
// only counted, so the subscriber costs a copy and stays far faster than rostopic hz, which cannot keep
// up with a 128x128 ClothState in Python). For each topic, after its first message and `--skip` seconds
// more (start-up), it records the arrival time (wall clock) of every message for `--seconds` seconds and
// prints
//   {"seconds": 10.0, "topics": {"/cloth_node/state": {"messages": 501, "rate_hz": 50.0,
//     "period_ms": {"p50": 20.0, "p90": 20.3, "p99": 21.0, "max": 24.1}, "bytes": 786520,
//     "stamp_rate_hz": 50.0}, ...}}
// stamp_rate_hz is the rate of the messages' own header stamps (messages whose first field is a Header):
// the publisher's clock, without the transport's jitter. A topic with no message inside --wait seconds
// reports "messages": 0. Exit status 0 when every topic got at least two messages, 1 otherwise.
// --queue is the subscriber's queue: 1 (the default) counts what a subscriber that only wants the newest
// message gets; cloth_node sends the frames a late tick caught up on back to back (up to 6), so a
// subscriber that wants every frame, and this tool counting them, needs a queue that deep.
// --seconds, --wait and --skip take finite numbers (a wait of inf would never end); a topic must be a valid ROS
// name. A bad option or topic exits 2 before anything is subscribed; --help prints the usage and exits 0.
#include "cloth_sim/core/constants.h"
#include "cloth_sim/ros/message_definition.h"
#include "tool_common.h"

#include <ros/names.h>
#include <ros/ros.h>
#include <topic_tools/shape_shifter.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace {

constexpr double kDefaultSeconds = 10.0;
constexpr double kDefaultWait_s = 30.0;
constexpr double kDefaultSkip_s = 1.0;
constexpr double kDefaultQueue = 1.0;
constexpr double kMaxQueue = 1000.0;
/// The longest --seconds, --wait or --skip, s (a day): their sum is the deadline, which must stay finite.
constexpr double kMaxTopicSpan_s = 86400.0;
using cloth_sim::core::kMillisecondsPerSecond;
constexpr double kPollPeriod_s = 0.01;
/// A std_msgs/Header's serialised start: uint32 seq, then the stamp as uint32 seconds and nanoseconds.
constexpr std::size_t kStampOffset = 4;
constexpr std::size_t kStampBytes = 8;
constexpr double kNanosecondsPerSecond = 1e9;

/// What one topic has seen: arrival times (wall, s) and header stamps (s, when the type has a header).
struct TopicRecord {
  std::string topic;
  double first_arrival_s = -1.0;
  std::vector<double> arrivals_s;
  std::vector<double> stamps_s;
  std::uint64_t bytes = 0;
  bool has_header = false;
  /// Whether the type's first field is its Header: read once, from the first message's definition (it is
  /// the same for every message of a topic, and scanning it per message would cost a flood of small ones).
  std::optional<bool> headed;
  std::vector<std::uint8_t> buffer;  ///< the last message's bytes (ShapeShifter gives them only by copy)
};

double percentile(std::vector<double> sorted, double fraction) {
  if (sorted.empty()) return 0.0;
  std::sort(sorted.begin(), sorted.end());
  const double position = fraction * static_cast<double>(sorted.size() - 1);
  const std::size_t below = static_cast<std::size_t>(position);
  const std::size_t above = std::min(below + 1, sorted.size() - 1);
  return sorted[below] + (position - static_cast<double>(below)) * (sorted[above] - sorted[below]);
}

/// Messages per second over the span from the first to the last sample (N - 1 intervals).
double rateHz(const std::vector<double>& times_s) {
  if (times_s.size() < 2) return 0.0;
  const double span_s = times_s.back() - times_s.front();
  return span_s > 0.0 ? static_cast<double>(times_s.size() - 1) / span_s : 0.0;
}

class RateMeter {
 public:
  RateMeter(double seconds, double skip_s, std::uint32_t queue) : seconds_(seconds), skip_s_(skip_s), queue_(queue) {}

  void subscribe(ros::NodeHandle& handle, const std::string& topic) {
    auto record = std::make_shared<TopicRecord>();
    record->topic = topic;
    records_.push_back(record);
    // A short queue: a late subscriber must not hide a slow publisher behind a backlog it works off later.
    subscribers_.push_back(handle.subscribe<topic_tools::ShapeShifter>(
        topic, queue_, [this, record](const topic_tools::ShapeShifter::ConstPtr& message) { onMessage(*record, *message); },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay()));
  }

  /// True once every topic has been recorded for its whole window.
  bool done(double now_s) const {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& record : records_) {
      if (record->first_arrival_s < 0.0 || now_s < record->first_arrival_s + skip_s_ + seconds_) return false;
    }
    return true;
  }

  /// The JSON line; *all_measured is false when a topic got fewer than two messages.
  std::string report(bool* all_measured) const {
    std::lock_guard<std::mutex> lock(mutex_);
    std::ostringstream out;
    out.precision(6);
    out << "{\"seconds\": " << seconds_ << ", \"topics\": {";
    *all_measured = true;
    for (std::size_t t = 0; t < records_.size(); ++t) {
      const TopicRecord& record = *records_[t];
      std::vector<double> periods_ms;
      for (std::size_t i = 1; i < record.arrivals_s.size(); ++i) {
        periods_ms.push_back((record.arrivals_s[i] - record.arrivals_s[i - 1]) * kMillisecondsPerSecond);
      }
      const std::size_t count = record.arrivals_s.size();
      if (count < 2) *all_measured = false;
      out << (t ? ", " : "") << cloth_sim::bench::jsonQuoted(record.topic) << ": {\"messages\": " << count
          << ", \"rate_hz\": " << rateHz(record.arrivals_s) << ", \"period_ms\": {\"p50\": "
          << percentile(periods_ms, 0.5) << ", \"p90\": " << percentile(periods_ms, 0.9)
          << ", \"p99\": " << percentile(periods_ms, 0.99) << ", \"max\": "
          << (periods_ms.empty() ? 0.0 : *std::max_element(periods_ms.begin(), periods_ms.end()))
          << "}, \"bytes\": " << (count ? record.bytes / count : 0);
      if (record.has_header) out << ", \"stamp_rate_hz\": " << rateHz(record.stamps_s);
      out << "}";
    }
    out << "}}";
    return out.str();
  }

 private:
  void onMessage(TopicRecord& record, const topic_tools::ShapeShifter& message) {
    const double now_s = ros::WallTime::now().toSec();
    std::lock_guard<std::mutex> lock(mutex_);
    if (record.first_arrival_s < 0.0) record.first_arrival_s = now_s;
    if (now_s < record.first_arrival_s + skip_s_ || now_s > record.first_arrival_s + skip_s_ + seconds_) return;
    record.arrivals_s.push_back(now_s);
    record.bytes += message.size();
    if (!record.headed) record.headed = cloth_sim::definitionStartsWithHeader(message.getMessageDefinition());
    if (*record.headed && message.size() >= kStampOffset + kStampBytes) {
      record.buffer.resize(message.size());
      ros::serialization::OStream stream(record.buffer.data(), static_cast<std::uint32_t>(record.buffer.size()));
      message.write(stream);
      std::uint32_t stamp[2];
      std::memcpy(stamp, record.buffer.data() + kStampOffset, kStampBytes);
      record.has_header = true;
      record.stamps_s.push_back(stamp[0] + stamp[1] / kNanosecondsPerSecond);
    }
  }

  double seconds_;
  double skip_s_;
  std::uint32_t queue_;
  mutable std::mutex mutex_;
  std::vector<std::shared_ptr<TopicRecord>> records_;
  std::vector<ros::Subscriber> subscribers_;
};

constexpr const char* kUsage = "usage: cloth_topic_rate [--seconds S] [--wait S] [--skip S] [--queue N] TOPIC...\n";

int usage(const std::string& reason) {
  std::fprintf(stderr, "cloth_topic_rate: %s\n%s", reason.c_str(), kUsage);
  return cloth_sim::bench::kExitUsage;
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "cloth_topic_rate", ros::init_options::AnonymousName);
  double seconds = kDefaultSeconds;
  double wait_s = kDefaultWait_s;
  double skip_s = kDefaultSkip_s;
  double queue = kDefaultQueue;
  std::vector<std::string> topics;
  for (int i = 1; i < argc; ++i) {
    const std::string argument = argv[i];
    if (argument == "--help" || argument == "-h") {
      std::printf("%s", kUsage);
      return cloth_sim::bench::kExitOk;
    }
    double* value = argument == "--seconds" ? &seconds : argument == "--wait" ? &wait_s : argument == "--skip" ? &skip_s
                    : argument == "--queue" ? &queue : nullptr;
    if (value) {
      if (i + 1 >= argc) return usage("missing the value of " + argument);
      const std::string text = argv[++i];
      // Finite only: an infinite --seconds, --wait or --skip would never end and print inf, which is not JSON.
      const std::optional<double> parsed = cloth_sim::bench::parseDouble(text);
      if (!parsed || *parsed < 0.0) return usage(argument + " " + text + ": takes a finite number >= 0");
      if (value != &queue && *parsed > kMaxTopicSpan_s) {
        return usage(argument + " " + text + ": at most " +
                     std::to_string(static_cast<int>(kMaxTopicSpan_s)) + " s");
      }
      *value = *parsed;
    } else if (!argument.empty() && argument[0] == '-') {
      return usage("unknown option " + argument);
    } else {
      // Checked here and resolved below: subscribe() would throw ros::InvalidNameException and abort. An
      // empty name is valid to ros::names but would resolve to the namespace itself.
      std::string problem;
      if (argument.empty()) return usage("an empty topic name");
      if (!ros::names::validate(argument, problem)) return usage("topic " + argument + ": " + problem);
      topics.push_back(argument);
    }
  }
  if (topics.empty()) return usage("no topic given");
  if (seconds <= 0.0) return usage("--seconds must be positive");
  if (queue < 1.0 || queue > kMaxQueue || queue != std::floor(queue)) {
    return usage("--queue must be a whole number in [1, " + std::to_string(static_cast<int>(kMaxQueue)) + "]");
  }

  ros::NodeHandle handle;
  // What ros::names::validate lets through and a subscription does not: a private name (~x: a NodeHandle
  // refuses it) and one that resolves to the root namespace itself (/).
  for (const std::string& topic : topics) {
    std::string resolved;
    try {
      resolved = handle.resolveName(topic);
    } catch (const ros::InvalidNameException& e) {
      return usage("topic " + topic + ": " + e.what());
    }
    if (resolved.empty() || resolved == "/") return usage("topic " + topic + ": names the root namespace, not a topic");
  }
  RateMeter meter(seconds, skip_s, static_cast<std::uint32_t>(queue));
  for (const std::string& topic : topics) meter.subscribe(handle, topic);
  // Two threads: a 5 MB message being copied on one topic does not delay the other's arrival times.
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const double give_up_s = ros::WallTime::now().toSec() + wait_s + skip_s + seconds;
  while (ros::ok() && !meter.done(ros::WallTime::now().toSec()) && ros::WallTime::now().toSec() < give_up_s) {
    ros::WallDuration(kPollPeriod_s).sleep();
  }
  spinner.stop();
  bool all_measured = false;
  std::printf("%s\n", meter.report(&all_measured).c_str());
  return all_measured ? cloth_sim::bench::kExitOk : cloth_sim::bench::kExitRunFailed;
}
