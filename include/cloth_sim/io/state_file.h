// State files: a whole simulation snapshot (scene options with their live tuning, the integrated state,
// and the inputs: grasps, pin hooks, wind) on disk, read back to the same bits. ROS-free. The format is
// documented in doc/STATE_FILE.md: a 32-byte header (magic, version, byte-order mark, payload length,
// CRC-32) and a payload of tagged sections (the options as scene YAML, then binary arrays).
#pragma once

#include "cloth_sim/core/options.h"
#include "cloth_sim/core/snapshot.h"

#include <cstddef>
#include <cstdint>
#include <string>

namespace cloth_sim::core {

struct StateFileFormat {
  /// The first 8 bytes of every state file.
  static constexpr char kMagic[8] = {'C', 'L', 'O', 'T', 'H', 'S', 'A', 'V'};
  /// Written now; readers accept 1 up to this (a newer file is refused with its version). Version 2 added
  /// the guard's memory (GARD); a version 1 file restores with a fresh one. Version 3 added the grippers
  /// (GRIP) and the frame colliders' tracks (LINK); older files restore with none. Version 4 added the
  /// last frame's motion (CALM), which `auto` substeps read; older files restore with none measured.
  /// Version 5 added the sleep count and the drive it was counted under (SLEP); older files restore awake.
  /// Version 6 added the saved frame's substeps (LAST); older files report what the next frame takes.
  /// Version 7 added where the calm frames began and the largest step of the cloth's rest (ANCH); an older
  /// file's calm cloth counts from where it was saved, with a largest step of 0.
  static constexpr std::uint32_t kVersion = 7;
  /// Written in the writer's byte order: read back as 0x04030201 on a machine of the other order.
  static constexpr std::uint32_t kByteOrderMark = 0x01020304;
  static constexpr std::size_t kHeaderBytes = 32;
  /// Allowance for the options text and the section headers, bytes.
  static constexpr std::size_t kFixedAllowanceBytes = std::size_t{1} << 20;
  /// Per particle: 48 bytes of positions and velocities, at most 52 of pin data (index, hook, travel),
  /// at most 28 of gripper data (index, offset), 24 of the calm frames' anchor and room for its pin in the
  /// options text.
  static constexpr std::size_t kMaxBytesPerParticle = 256;
  /// Larger files are refused before anything is read: the largest grid's snapshot fits with room.
  static constexpr std::size_t kMaxFileBytes =
      kFixedAllowanceBytes + kMaxBytesPerParticle * static_cast<std::size_t>(OptionLimits::kMaxGridSide) *
                                 static_cast<std::size_t>(OptionLimits::kMaxGridSide);
};

/// Writes the snapshot to `path` through a temporary file in the same folder renamed over it, so a
/// failed or interrupted save leaves either the old file or none, never half of one. An existing file is
/// replaced only if it is a state file. False with the reason in *error (the folder missing or not
/// writable, the disk full, another kind of file in the way).
bool writeStateFile(const std::string& path, const SimulationSnapshot& snapshot, std::string* error);

/// Reads a state file written by writeStateFile. False with the reason in *error, and *snapshot
/// unchanged, for a missing or oversized file, wrong magic, unsupported version, other byte order, a
/// length or checksum mismatch (truncated or corrupted), or contents that do not parse or whose options
/// do not validate. Whether it fits a running simulation is Simulation::restore's to check. Messages
/// quote no file content beyond numbers.
bool readStateFile(const std::string& path, SimulationSnapshot* snapshot, std::string* error);

/// The bytes writeStateFile puts on disk, and their parser (used by the two above; exposed for tests
/// and fuzzing).
std::string encodeStateFile(const SimulationSnapshot& snapshot);
bool decodeStateFile(const std::string& bytes, SimulationSnapshot* snapshot, std::string* error);

/// CRC-32 (IEEE 802.3, the one zlib and PNG use) of `size` bytes.
std::uint32_t crc32(const void* data, std::size_t size);

}  // namespace cloth_sim::core
