#include "cloth_sim/core/camera.h"

namespace cloth_sim::core {

const char* depthNoiseName(DepthNoise noise) { return noise == DepthNoise::kKinect ? "kinect" : "none"; }

bool parseDepthNoiseName(const std::string& name, DepthNoise* noise) {
  if (name == "none") {
    *noise = DepthNoise::kNone;
  } else if (name == "kinect") {
    *noise = DepthNoise::kKinect;
  } else {
    return false;
  }
  return true;
}

}  // namespace cloth_sim::core
