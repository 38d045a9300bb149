// libFuzzer target: scene-file text, as ~load_scene reads it, through the YAML parser, applySceneYaml and
// validateSceneOptions; a scene that validates and is small enough to run fast is then built and advanced
// a few frames, and everything it hands out must be finite. Seeds: config/scenes and test/ros/scenes
// (make fuzz); dictionary: the scene keys (scene_keys_dict.cpp).
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/io/scene_file.h"
#include "fuzz_checks.h"

#include <yaml-cpp/yaml.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace {

using cloth_sim::core::SceneOptions;

// Bounds on the work one input may ask for, so that an execution stays in milliseconds; the options'
// own limits (tens of thousands of substeps on a 512 x 512 grid) are for a machine, not for a fuzzer.
constexpr int kMaxParticles = 36;
constexpr int kMaxSubsteps = 4;
constexpr int kMaxSolverIterations = 50;
constexpr int kFrames = 2;

bool smallEnoughToRun(const SceneOptions& options) {
  return options.rows * options.cols <= kMaxParticles && options.substeps <= kMaxSubsteps &&
         options.solver.max_iterations <= kMaxSolverIterations;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using cloth_sim::fuzz::require;
  const std::string text(reinterpret_cast<const char*>(data), size);
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception&) {
    return 0;  // loadSceneFile reports this as "not valid YAML"
  }
  SceneOptions options;
  std::vector<std::string> errors;
  if (!cloth_sim::core::applySceneYaml(root, "fuzz", &options, &errors)) {
    require(!errors.empty(), "applySceneYaml refused without saying why");
    return 0;
  }
  require(errors.empty(), "applySceneYaml accepted with errors");
  if (!cloth_sim::core::validateSceneOptions(options).empty() || !smallEnoughToRun(options)) return 0;

  cloth_sim::core::Simulation simulation(options);  // throws (a finding) if validation let a bad option through
  for (int frame = 0; frame < kFrames; ++frame) {
    const cloth_sim::core::FrameReport report = simulation.advanceFrame();
    cloth_sim::fuzz::requireFiniteSimulation(simulation, report);
  }
  return 0;
}
