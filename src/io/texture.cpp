#include "cloth_sim/io/texture.h"

#include "cloth_sim/core/simulation.h"
#include "cloth_sim/io/bounded_file.h"

#include <stb_image.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>

namespace cloth_sim::core {

namespace {

constexpr int kChannels = 3;  // RGB; stb converts grey and RGBA for us
constexpr float kByteToUnit = 1.0f / 255.0f;

}  // namespace

std::string textureFileProblem(const std::string& path) {
  std::error_code ec;
  const std::filesystem::file_status status = std::filesystem::status(path, ec);
  if (!std::filesystem::exists(status)) return "no such file";
  if (!std::filesystem::is_regular_file(status)) return "not a regular file";
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) return "cannot be read: " + ec.message();
  if (size > kMaxTextureFileBytes) {
    return std::to_string(size) + " bytes: larger than the limit of " + std::to_string(kMaxTextureFileBytes) + " bytes";
  }
  return "";
}

bool sampleTextureImage(const std::string& path, const Eigen::Matrix2Xd& uv, Eigen::Matrix3Xf* colors,
                        std::string* error) {
  std::string file;
  std::string read_error;
  if (!readBoundedRegularFile(path, kMaxTextureFileBytes, &file, &read_error)) {
    *error = "texture " + path + ": " + read_error;
    return false;
  }
  const auto* file_bytes = reinterpret_cast<const stbi_uc*>(file.data());
  const int file_size = static_cast<int>(file.size());  // at most 16 MiB: fits
  int width = 0;
  int height = 0;
  int channels_in_file = 0;
  // The header alone first: a small compressed file may announce gigabytes of pixels.
  if (stbi_info_from_memory(file_bytes, file_size, &width, &height, &channels_in_file) == 0) {
    *error = "texture " + path + ": " + (stbi_failure_reason() ? stbi_failure_reason() : "not an image");
    return false;
  }
  const std::uint64_t pixels_announced = static_cast<std::uint64_t>(width) * static_cast<std::uint64_t>(height);
  if (width <= 0 || height <= 0 || pixels_announced > kMaxTexturePixels) {
    *error = "texture " + path + ": " + std::to_string(width) + " x " + std::to_string(height) +
             " pixels: more than the limit of " + std::to_string(kMaxTexturePixels) + " pixels (4096 x 4096)";
    return false;
  }
  std::unique_ptr<unsigned char, void (*)(void*)> pixels(
      stbi_load_from_memory(file_bytes, file_size, &width, &height, &channels_in_file, kChannels), stbi_image_free);
  if (!pixels) {
    *error = "texture " + path + ": " + (stbi_failure_reason() ? stbi_failure_reason() : "cannot be read");
    return false;
  }
  // The return type must be spelled out: with `auto` the lambda would return an Eigen expression that
  // refers to a temporary Vector3f destroyed on return, and every sample would read freed stack.
  const auto texel = [&](int x, int y) -> Eigen::Vector3f {
    const unsigned char* p = pixels.get() + (static_cast<std::size_t>(y) * width + x) * kChannels;
    return Eigen::Vector3f(p[0], p[1], p[2]) * kByteToUnit;
  };
  colors->resize(3, uv.cols());
  for (Eigen::Index i = 0; i < uv.cols(); ++i) {
    // u = 0 and u = 1 fall on the first and last texel centres; outside [0, 1] clamps.
    const double x = std::clamp(uv(0, i), 0.0, 1.0) * (width - 1);
    const double y = std::clamp(uv(1, i), 0.0, 1.0) * (height - 1);
    const int x0 = static_cast<int>(std::floor(x));
    const int y0 = static_cast<int>(std::floor(y));
    const int x1 = std::min(x0 + 1, width - 1);
    const int y1 = std::min(y0 + 1, height - 1);
    const float fx = static_cast<float>(x - x0);
    const float fy = static_cast<float>(y - y0);
    colors->col(i) = (1 - fy) * ((1 - fx) * texel(x0, y0) + fx * texel(x1, y0)) +
                     fy * ((1 - fx) * texel(x0, y1) + fx * texel(x1, y1));
  }
  return true;
}

bool sceneVertexColors(const std::string& path, const Eigen::Matrix2Xd& uv, Eigen::Matrix3Xf* colors,
                       std::string* error) {
  if (path.empty()) {
    *colors = checkerColors(uv);
    return true;
  }
  Eigen::Matrix3Xf sampled;
  if (!sampleTextureImage(path, uv, &sampled, error)) return false;
  *colors = sampled;
  return true;
}

}  // namespace cloth_sim::core
