// libFuzzer target: state files, as ~load_state reads them, through decodeStateFile and
// Simulation::restore; a snapshot that is accepted is advanced a few frames, and everything the
// simulation then hands out must be finite. The first byte chooses what the rest is: the whole file
// (header included), or only its payload, wrapped here in a header with the right length and CRC-32 so
// that the fuzzer reaches the sections behind the checksum. Seeds: state files of the built-in scenes
// at 6 x 6 with grasps and wind (state_file_seeds.cpp, written at build time).
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/io/state_file.h"
#include "fuzz_checks.h"

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

namespace {

using cloth_sim::core::StateFileFormat;

constexpr int kMaxParticles = 36;  ///< an execution stays in milliseconds
constexpr int kFrames = 2;
constexpr std::size_t kLengthOffset = 16;
constexpr std::size_t kChecksumOffset = 24;

/// A header that announces `payload` exactly (the first 16 bytes as every writer puts them).
std::string wrapped(const std::string& payload) {
  std::string file(StateFileFormat::kHeaderBytes, '\0');
  std::memcpy(file.data(), StateFileFormat::kMagic, sizeof(StateFileFormat::kMagic));
  const std::uint32_t mark = StateFileFormat::kByteOrderMark;
  const std::uint32_t version = StateFileFormat::kVersion;
  const std::uint64_t length = payload.size();
  const std::uint32_t checksum = cloth_sim::core::crc32(payload.data(), payload.size());
  std::memcpy(file.data() + sizeof(StateFileFormat::kMagic), &mark, sizeof(mark));
  std::memcpy(file.data() + sizeof(StateFileFormat::kMagic) + sizeof(mark), &version, sizeof(version));
  std::memcpy(file.data() + kLengthOffset, &length, sizeof(length));
  std::memcpy(file.data() + kChecksumOffset, &checksum, sizeof(checksum));
  return file + payload;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using cloth_sim::fuzz::require;
  if (size == 0) return 0;
  const std::string rest(reinterpret_cast<const char*>(data) + 1, size - 1);
  const std::string bytes = (data[0] & 1u) ? wrapped(rest) : rest;
  cloth_sim::core::SimulationSnapshot snapshot;
  std::string error;
  if (!cloth_sim::core::decodeStateFile(bytes, &snapshot, &error)) {
    require(!error.empty(), "decodeStateFile refused without saying why");
    return 0;
  }
  if (snapshot.options.rows * snapshot.options.cols > kMaxParticles) return 0;
  // decodeStateFile validated the options: building the scene must not throw (that would be a finding).
  cloth_sim::core::Simulation simulation(snapshot.options);
  if (!simulation.restore(snapshot, &error)) {
    require(!error.empty(), "restore refused without saying why");
    return 0;
  }
  for (int frame = 0; frame < kFrames; ++frame) {
    const cloth_sim::core::FrameReport report = simulation.advanceFrame();
    cloth_sim::fuzz::requireFiniteSimulation(simulation, report);
  }
  return 0;
}
