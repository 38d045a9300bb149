// What cloth_bench's timing run and its measuring modes (--accuracy, --spatial, --stability-map, --terms,
// --solver-sweep) share: exit codes and command-line numbers (from tool_common.h), KEY=VALUE scene overrides
// read exactly as the node reads a parameter, the scene built from them, and the "released flat" start (--dynamic).
#pragma once

#include "cloth_sim/core/options.h"
#include "cloth_sim/io/scene_file.h"
#include "tool_common.h"

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <optional>
#include <string>
#include <vector>

namespace cloth_sim::bench {

/// The longest simulated span a measuring mode takes (--seconds), s: 500,000 frames at 50 Hz, longer than any
/// measurement here finishes, and a frame count an int holds at any frame rate (at most 1000 Hz).
constexpr double kMaxSpan_s = 1e4;
/// The most memory one trajectory a measuring mode keeps may take, bytes (1 GB; two or three are kept at
/// once): 2,083 s of a 20 x 20 cloth at 50 Hz, 50 s of 128 x 128.
constexpr double kBytesPerGigabyte = 1e9;
constexpr double kMaxTrajectoryBytes = 1.0 * kBytesPerGigabyte;

// ---- scene overrides -----------------------------------------------------------------------------------------------

/// One scene key to overlay, from --set or from a flag that stands for one.
struct SceneOverride {
  std::string flag;  ///< what the user typed it as ("--set", "--rows"), for error messages
  std::string key;
  std::string value;
};

/// Reads "--set KEY=VALUE"'s value into *overrides; a text without KEY= goes to *errors.
inline void parseSceneSetting(const std::string& text, std::vector<SceneOverride>* overrides,
                              std::vector<std::string>* errors) {
  const std::size_t equals = text.find('=');
  if (equals == std::string::npos || equals == 0) {
    errors->push_back("--set " + text + ": expected KEY=VALUE");
    return;
  }
  overrides->push_back({"--set", text.substr(0, equals), text.substr(equals + 1)});
}

/// Overlays one KEY=VALUE: VALUE is YAML, so "20000", "[0, 1, 0]" and "implicit_euler" are a number, a list and a
/// string as they would be in a scene file. Problems go to *errors.
inline void applyOverride(const SceneOverride& entry, core::SceneOptions* scene, std::vector<std::string>* errors) {
  YAML::Node map(YAML::NodeType::Map);
  try {
    map[entry.key] = YAML::Load(entry.value);
  } catch (const YAML::Exception& e) {
    errors->push_back(entry.flag + " " + entry.key + "=" + entry.value + ": not valid YAML: " + e.what());
    return;
  }
  core::applySceneYaml(map, entry.flag, scene, errors);
}

/// The scene file (a built-in name resolved in scenes_dir, or a path), then the overrides in order. Not yet
/// validated: the caller may change more (--dynamic, --grid) and validates once. False with the problems in *errors.
/// The benchmarks measure the physics: a cloth at rest is computed like any other unless an override
/// sets sleep_speed (a scene file's own sleep_speed is overridden too).
inline bool loadSceneWithOverrides(const std::string& scene_name, const std::string& scenes_dir,
                                   const std::vector<SceneOverride>& overrides, core::SceneOptions* scene,
                                   std::vector<std::string>* errors) {
  if (!core::loadSceneFile(core::resolveScenePath(scene_name, scenes_dir), scene, errors)) return false;
  scene->sleep_speed_m_per_s = 0.0;
  for (const SceneOverride& entry : overrides) applyOverride(entry, scene, errors);
  return errors->empty();
}

/// Appends validateSceneOptions' problems to *errors; true when there are none at all.
inline bool validateInto(const core::SceneOptions& scene, std::vector<std::string>* errors) {
  for (const std::string& problem : core::validateSceneOptions(scene)) errors->push_back(problem);
  return errors->empty();
}

// ---- released flat -------------------------------------------------------------------------------------------------

/// Lays the cloth flat at the height of its top edge, rows running along +y from the top edge, the two top corners
/// pinned where they lie, so it swings down (the same start as bullet_cloth.h's dynamic patch: top-left corner at
/// (-width / 2, 0, top edge height), world frame). The scene's pin_positions, pin_travel_time and pin motion go
/// with the pins they replace: kept, the drape's corners were still carried to its hooks, and a scene pinning its
/// top edge at hooks of its own was refused for more hooks than pins.
inline void makeDynamic(core::SceneOptions* scene) {
  const double top_edge_z_m = scene->origin_m.z();
  scene->u_axis = Eigen::Vector3d::UnitX();
  scene->v_axis = Eigen::Vector3d::UnitY();
  scene->origin_m = Eigen::Vector3d(-0.5 * scene->width_m, 0.0, top_edge_z_m);
  scene->pins = {"top_left", "top_right"};
  scene->pin_positions_m.clear();
  scene->pin_travel_time_s = 0.0;
  scene->pin_motion_amplitude_m.setZero();
}

/// Why a scene cannot be released flat (after makeDynamic): its outline removes a top corner --dynamic pins.
/// Empty when it can be, or when the scene has problems of its own (validateSceneOptions names those). Without
/// this the refusal read "pins: particle 0 is outside the outline", a key the command line never set.
inline std::string dynamicPinsProblem(const core::SceneOptions& scene) {
  if (scene.outline.shape == core::OutlineOptions::Shape::kNone) return "";
  core::SceneOptions unpinned = scene;
  unpinned.pins.clear();
  if (!core::validateSceneOptions(unpinned).empty()) return "";  // outlineMask needs a valid grid
  const std::vector<std::uint8_t> kept = core::outlineMask(scene);
  std::string pin_error;
  for (const int pin : core::resolvePins(scene.pins, scene.rows, scene.cols, &pin_error)) {
    if (kept[static_cast<std::size_t>(pin)] == 0) {
      return "--dynamic pins the two top corners, and particle " + std::to_string(pin) +
             " is outside the cloth's outline";
    }
  }
  return "";
}

}  // namespace cloth_sim::bench
