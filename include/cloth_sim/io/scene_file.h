// Scene files: YAML maps whose keys are the SceneOptions fields (the same names as the node's private
// parameters). ROS-free; the node feeds its parameters through applySceneYaml too, so a file and a
// parameter are read by one parser and validated by one function.
#pragma once

#include "cloth_sim/core/options.h"
#include "cloth_sim/io/texture.h"  // kMaxTextureFileBytes

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <string>
#include <vector>

namespace cloth_sim::core {

/// Largest scene file read, bytes (1 MiB: the built-in scenes are under 2 KB). A bigger file is refused
/// before it is opened, so no request can make the node read (and quote) a huge file.
constexpr std::uintmax_t kMaxSceneFileBytes = 1024 * 1024;

/// The YAML core schema's tag prefix (`!!str` is this and `str`): the reader checks a scalar's type by it,
/// and the node tags its parameters' values with it.
inline constexpr const char* kCoreTagPrefix = "tag:yaml.org,2002:";

/// Every key a scene map may hold.
const std::vector<std::string>& sceneKeys();

/// Overlays the keys of `map` onto *options. `source` prefixes each error ("scene file x.yaml",
/// "parameter"). Unknown keys and wrong types are errors that name the key, the value and what was
/// expected. Returns true when there were none; *options then holds the overlay (not yet validated).
bool applySceneYaml(const YAML::Node& map, const std::string& source, SceneOptions* options,
                    std::vector<std::string>* errors);

/// A built-in scene name ("flag") maps to <scenes_dir>/flag.yaml; anything with a '/' or ending in
/// .yaml/.yml is taken as a path (a relative one is relative to the working directory); "" stays "".
std::string resolveScenePath(const std::string& name_or_path, const std::string& scenes_dir);

/// Names of the built-in scenes: the .yaml files in scenes_dir, sorted.
std::vector<std::string> builtinSceneNames(const std::string& scenes_dir);

/// Reads a scene file on top of the defaults and validates the result. A relative texture path is taken
/// relative to the file's folder. False with every problem in *errors. Refused before anything is read:
/// an empty path, a name not ending in .yaml or .yml, anything but a regular file (directories, FIFOs,
/// devices), a file over kMaxSceneFileBytes, a texture that is not a regular file or is over
/// kMaxTextureFileBytes. Errors quote at most a short, cut excerpt of the file's text. A key given twice
/// is an error that names it.
bool loadSceneFile(const std::string& path, SceneOptions* options, std::vector<std::string>* errors);

/// The options as a scene map holding every key of sceneKeys(), numbers printed so that applySceneYaml
/// reads back the same bits (17 significant digits), strings double-quoted. Used by the state file.
std::string sceneYaml(const SceneOptions& options);

}  // namespace cloth_sim::core
