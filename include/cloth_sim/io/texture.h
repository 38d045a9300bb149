// Per-vertex colours sampled from an image (paper §3.3: texture coordinates per grid point, Gouraud
// shading). ROS-free; images are read with stb_image (PNG, JPEG, BMP, TGA...).
#pragma once

#include <Eigen/Core>

#include <string>

namespace cloth_sim::core {

/// Samples the image at each uv (u across, v down the image; bilinear), RGB in [0, 1]. False with
/// *error if the file cannot be read.
bool sampleTextureImage(const std::string& path, const Eigen::Matrix2Xd& uv, Eigen::Matrix3Xf* colors,
                        std::string* error);

/// A scene's per-vertex colours: sampled from the image at `path`, or the built-in checker pattern
/// (checkerColors) when `path` is empty. False with *error (and *colors untouched) if the image cannot
/// be read.
bool sceneVertexColors(const std::string& path, const Eigen::Matrix2Xd& uv, Eigen::Matrix3Xf* colors,
                       std::string* error);

}  // namespace cloth_sim::core
