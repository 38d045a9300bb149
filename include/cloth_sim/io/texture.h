// Per-vertex colours sampled from an image (paper §3.3: texture coordinates per grid point, Gouraud
// shading). ROS-free; images are read with stb_image (PNG, JPEG, BMP, TGA...).
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <string>

namespace cloth_sim::core {

/// Largest texture image file, bytes (16 MiB).
constexpr std::uintmax_t kMaxTextureFileBytes = 16 * 1024 * 1024;
/// Most pixels (width x height) a texture may decode to: 4096 x 4096, 50 MB as RGB. Checked from the
/// image's header before it is decoded: a 255 KB PNG of 16384 x 16384 decoded to 1 GB. A cloth has at most
/// 512 x 512 vertices, so a larger image adds nothing to its colours.
constexpr std::uint64_t kMaxTexturePixels = std::uint64_t{4096} * 4096;

/// Why the file at `path` cannot be a texture ("no such file", "not a regular file", over
/// kMaxTextureFileBytes), from its metadata alone (nothing is opened, so a FIFO cannot block); empty if
/// it may be. sampleTextureImage checks the same again on the file it opens.
std::string textureFileProblem(const std::string& path);

/// Samples the image at each uv (u across, v down the image; bilinear), RGB in [0, 1]. False with
/// *error if the file cannot be read, is not a regular file (opened non-blocking: a FIFO is refused, not
/// waited on), is over kMaxTextureFileBytes, or its header announces more than kMaxTexturePixels pixels.
/// Every way a texture arrives (start-up parameters, ~load_scene, ~load_state) comes through here.
bool sampleTextureImage(const std::string& path, const Eigen::Matrix2Xd& uv, Eigen::Matrix3Xf* colors,
                        std::string* error);

/// A scene's per-vertex colours: sampled from the image at `path`, or the built-in checker pattern
/// (checkerColors) when `path` is empty. False with *error (and *colors untouched) if the image cannot
/// be read.
bool sceneVertexColors(const std::string& path, const Eigen::Matrix2Xd& uv, Eigen::Matrix3Xf* colors,
                       std::string* error);

}  // namespace cloth_sim::core
