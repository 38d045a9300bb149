// One KEY=VALUE scene override, read exactly as the node reads a parameter: shared by cloth_bench's modes.
#pragma once

#include "cloth_sim/core/options.h"
#include "cloth_sim/io/scene_file.h"

#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

namespace cloth_sim::bench {

/// One scene key to overlay, from --set or from a flag that stands for one.
struct SceneOverride {
  std::string flag;  ///< what the user typed it as ("--set", "--rows"), for error messages
  std::string key;
  std::string value;
};

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

}  // namespace cloth_sim::bench
