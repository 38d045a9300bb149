// Writes the seeds of fuzz_state_file into the folder given: for each built-in scene at 6 x 6, advanced
// a few frames with wind and two grasps, its state file as a whole (first byte 0) and as a payload for
// the target to wrap (first byte 1).
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/io/scene_file.h"
#include "cloth_sim/io/state_file.h"

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

namespace {

constexpr int kSide = 6;
constexpr int kFrames = 5;

void writeSeed(const std::string& path, char mode, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.put(mode);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: state_file_seeds SCENES_DIR OUT_DIR\n");
    return 2;
  }
  namespace core = cloth_sim::core;
  for (const std::string& name : core::builtinSceneNames(argv[1])) {
    core::SceneOptions options;
    std::vector<std::string> errors;
    if (!core::loadSceneFile(core::resolveScenePath(name, argv[1]), &options, &errors)) return 1;
    options.rows = kSide;
    options.cols = kSide;
    options.texture.clear();
    core::Simulation simulation(options);
    simulation.setWindVelocity(Eigen::Vector3d(1.0, 2.0, 0.0));
    std::string error;
    core::GraspRequest hand;
    hand.id = 1;
    hand.particle = kSide * kSide - 1;
    hand.target_m = simulation.state().positions_m.col(hand.particle) + Eigen::Vector3d(0.1, 0.0, 0.0);
    simulation.grab(hand, &error);
    for (int frame = 0; frame < kFrames; ++frame) simulation.advanceFrame();
    const std::string file = core::encodeStateFile(simulation.snapshot());
    const std::string stem = std::string(argv[2]) + "/" + name;
    writeSeed(stem + ".file", '\0', file);
    writeSeed(stem + ".payload", '\1', file.substr(core::StateFileFormat::kHeaderBytes));
  }
  return 0;
}
