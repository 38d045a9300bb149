#include "cloth_sim/core/camera.h"

#include "cloth_sim/core/enum_names.h"

namespace cloth_sim::core {

namespace {

constexpr EnumNames<DepthNoise, 2> kDepthNoiseNames{{{DepthNoise::kNone, "none"}, {DepthNoise::kKinect, "kinect"}}};

}  // namespace

const char* depthNoiseName(DepthNoise noise) { return enumName(kDepthNoiseNames, noise); }

bool parseDepthNoiseName(const std::string& name, DepthNoise* noise) {
  return parseEnumName(kDepthNoiseNames, name, noise);
}

}  // namespace cloth_sim::core
