// cloth_message_bench: what the node's messages cost per frame, without a master or a network.
//
//   rosrun cloth_sim cloth_message_bench [--sizes 64,128,256] [--repeats 50] [--scene hanging]
//
// For each size it builds the scene at that many particles per side, advances it one frame, then times
// what the node does each frame for a subscriber of each topic: build the message from the simulation
// (src/ros/conversions.cpp, as cloth_node does) and serialise it (ros::serialization, as roscpp does once
// per publish when a subscriber is connected). Prints a markdown table (median over --repeats, ms) and
// the serialised sizes; doc/BENCHMARKS.md quotes it. --repeats takes 1 to 100000; a bad option, scene or size
// exits 2 before the table starts, --help prints the usage and exits 0.
#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/options.h"
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/io/scene_file.h"
#include "cloth_sim/io/texture.h"
#include "cloth_sim/ros/conversions.h"
#include "bench_common.h"

#include <ros/serialization.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace {

using cloth_sim::bench::kExitOk;
using cloth_sim::bench::kExitRunFailed;
using cloth_sim::bench::kExitUsage;
constexpr int kDefaultRepeats = 50;
/// The most --repeats: each repeat keeps one time per measurement, and 100,000 repeats of a 256x256 mesh
/// already take minutes; far more would only exhaust memory (2^31 repeats failed with bad_alloc).
constexpr int kMaxRepeats = 100000;
constexpr const char* kUsage =
    "usage: cloth_message_bench [--sizes 64,128,256] [--repeats N] [--scene NAME]\n";
using cloth_sim::core::kMillisecondsPerSecond;
constexpr double kBytesPerMebibyte = 1024.0 * 1024.0;
constexpr const char* kDefaultScene = "hanging";
constexpr const char* kFrameId = "world";

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values.empty() ? 0.0 : values[values.size() / 2];
}

/// Milliseconds of one call of `work`, median over `repeats` calls.
template <typename Work>
double medianMs(int repeats, Work&& work) {
  std::vector<double> times_ms;
  for (int r = 0; r < repeats; ++r) {
    const auto start = std::chrono::steady_clock::now();
    work();
    times_ms.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() *
                       kMillisecondsPerSecond);
  }
  return median(times_ms);
}

/// The message serialised as roscpp does it for a publish: length prefix and body in one buffer.
template <typename Message>
std::size_t serialise(const Message& message) {
  const ros::SerializedMessage serialized = ros::serialization::serializeMessage(message);
  return serialized.num_bytes;
}

struct Costs {
  int side = 0;
  double state_build_ms = 0.0, state_serialise_ms = 0.0, mesh_build_ms = 0.0, mesh_serialise_ms = 0.0;
  std::size_t state_bytes = 0, mesh_bytes = 0;
};

/// The scene at `side` particles per side, validated; false with the first problem in *error.
bool sceneAtSide(const cloth_sim::core::SceneOptions& scene, int side, cloth_sim::core::SceneOptions* options,
                 std::string* error) {
  *options = scene;
  options->rows = options->cols = side;
  const std::vector<std::string> problems = cloth_sim::core::validateSceneOptions(*options);
  if (!problems.empty()) {
    *error = problems.front();
    return false;
  }
  return true;
}

bool measure(const cloth_sim::core::SceneOptions& options, int side, int repeats, Costs* costs, std::string* error) {
  cloth_sim::core::Simulation simulation(options);
  Eigen::Matrix3Xf colors;
  if (!cloth_sim::core::sceneVertexColors(options.texture, simulation.grid().uv, &colors, error)) return false;
  simulation.setVertexColors(colors);
  simulation.advanceFrame();
  const ros::Time stamp(1.0);
  costs->side = side;
  const cloth_sim::ClothState state = cloth_sim::toStateMessage(simulation, kFrameId, stamp);
  const visualization_msgs::Marker mesh = cloth_sim::toMeshMarker(simulation, kFrameId, stamp);
  costs->state_bytes = serialise(state);
  costs->mesh_bytes = serialise(mesh);
  costs->state_build_ms = medianMs(repeats, [&] { cloth_sim::toStateMessage(simulation, kFrameId, stamp); });
  costs->state_serialise_ms = medianMs(repeats, [&] { serialise(state); });
  costs->mesh_build_ms = medianMs(repeats, [&] { cloth_sim::toMeshMarker(simulation, kFrameId, stamp); });
  costs->mesh_serialise_ms = medianMs(repeats, [&] { serialise(mesh); });
  return true;
}

std::vector<int> parseSizes(const std::string& text) {
  std::vector<int> sizes;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    char* end = nullptr;
    const long side = std::strtol(item.c_str(), &end, 10);
    if (end == item.c_str() || *end != '\0' || side < 2 || side > cloth_sim::core::OptionLimits::kMaxGridSide) return {};
    sizes.push_back(static_cast<int>(side));
  }
  return sizes;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> sizes{64, 128, 256};
  int repeats = kDefaultRepeats;
  std::string scene_name = kDefaultScene;
  for (int i = 1; i < argc; ++i) {
    const std::string argument = argv[i];
    if (argument == "--help" || argument == "-h") {
      std::printf("%s", kUsage);
      return kExitOk;
    }
    if (argument != "--sizes" && argument != "--repeats" && argument != "--scene") {
      std::fprintf(stderr, "cloth_message_bench: unknown option %s\n%s", argument.c_str(), kUsage);
      return kExitUsage;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "cloth_message_bench: %s needs a value\n%s", argument.c_str(), kUsage);
      return kExitUsage;
    }
    const std::string value = argv[++i];
    if (argument == "--sizes") {
      sizes = parseSizes(value);
      if (sizes.empty()) {
        std::fprintf(stderr, "cloth_message_bench: --sizes %s: takes sides in [2, %d] separated by commas\n",
                     value.c_str(), cloth_sim::core::OptionLimits::kMaxGridSide);
        return kExitUsage;
      }
    } else if (argument == "--repeats") {
      const std::optional<int> parsed = cloth_sim::bench::parseInt(value);
      if (!parsed || *parsed < 1 || *parsed > kMaxRepeats) {
        std::fprintf(stderr, "cloth_message_bench: --repeats %s: takes a whole number in [1, %d]\n", value.c_str(),
                     kMaxRepeats);
        return kExitUsage;
      }
      repeats = *parsed;
    } else {
      scene_name = value;
    }
  }
  // The scene and every size are checked before the table's header: a mistake prints no half table.
  cloth_sim::core::SceneOptions scene;
  std::vector<std::string> errors;
  if (!cloth_sim::core::loadSceneFile(cloth_sim::core::resolveScenePath(scene_name, CLOTH_SIM_SCENES_DIR), &scene,
                                      &errors)) {
    std::fprintf(stderr, "cloth_message_bench: --scene %s: %s\n", scene_name.c_str(),
                 errors.empty() ? "cannot read the scene" : errors.front().c_str());
    return kExitUsage;
  }
  std::vector<cloth_sim::core::SceneOptions> scenes(sizes.size());
  for (std::size_t s = 0; s < sizes.size(); ++s) {
    std::string error;
    if (!sceneAtSide(scene, sizes[s], &scenes[s], &error)) {
      std::fprintf(stderr, "cloth_message_bench: --scene %s at --sizes %d: %s\n", scene_name.c_str(), sizes[s],
                   error.c_str());
      return kExitUsage;
    }
  }
  std::printf("| grid | ~state build ms | ~state serialise ms | ~state MiB | ~mesh build ms | ~mesh serialise ms | "
              "~mesh MiB |\n|---|---|---|---|---|---|---|\n");
  for (std::size_t s = 0; s < sizes.size(); ++s) {
    const int side = sizes[s];
    Costs costs;
    std::string error;
    if (!measure(scenes[s], side, repeats, &costs, &error)) {
      std::fprintf(stderr, "cloth_message_bench: %dx%d: %s\n", side, side, error.c_str());
      return kExitRunFailed;
    }
    std::printf("| %dx%d | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f |\n", side, side, costs.state_build_ms,
                costs.state_serialise_ms, costs.state_bytes / kBytesPerMebibyte, costs.mesh_build_ms,
                costs.mesh_serialise_ms, costs.mesh_bytes / kBytesPerMebibyte);
    std::fflush(stdout);
  }
  return kExitOk;
}
