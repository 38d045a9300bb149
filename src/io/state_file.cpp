#include "cloth_sim/io/state_file.h"

#include "cloth_sim/io/bounded_file.h"
#include "cloth_sim/io/scene_file.h"

#include <yaml-cpp/yaml.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <type_traits>
#include <fcntl.h>
#include <unistd.h>

namespace cloth_sim::core {

namespace {

namespace fs = std::filesystem;
using F = StateFileFormat;

/// Section tags, in the order they are written. Version 1 has exactly these three.
constexpr char kOptionsTag[4] = {'O', 'P', 'T', 'S'};  ///< the options as scene YAML (sceneYaml)
constexpr char kStateTag[4] = {'S', 'T', 'A', 'T'};    ///< ClothState
constexpr char kInputsTag[4] = {'I', 'N', 'P', 'T'};   ///< ClothInputs
constexpr char kGuardTag[4] = {'G', 'A', 'R', 'D'};    ///< GuardMemory (version 2 on)
constexpr char kGrippersTag[4] = {'G', 'R', 'I', 'P'};  ///< ClothInputs::grippers (version 3 on)
constexpr char kLinksTag[4] = {'L', 'I', 'N', 'K'};     ///< ClothInputs::frame_colliders (version 3 on)
constexpr char kMotionTag[4] = {'C', 'A', 'L', 'M'};    ///< GuardMemory::frame_motion_m_per_s (version 4 on)
constexpr char kSleepTag[4] = {'S', 'L', 'E', 'P'};     ///< GuardMemory's calm frames and drive (version 5 on)
constexpr char kLastTag[4] = {'L', 'A', 'S', 'T'};      ///< the saved frame's substeps (version 6 on)
constexpr char kAnchorTag[4] = {'A', 'N', 'C', 'H'};    ///< calm_largest_step_m, calm_anchor_m (version 7 on)
constexpr std::size_t kSectionCount = 10;
/// How many of the sections above a file of each version holds (index: the version, 1 up to
/// StateFileFormat::kVersion): version 1 files end after the inputs, version 2 files after the guard's
/// memory, version 3 files after the frame colliders' tracks, version 4 files after the last frame's motion,
/// version 5 files after the sleep counters, version 6 files after the last frame's substeps.
constexpr std::array<std::size_t, StateFileFormat::kVersion + 1> kSectionsInVersion{0, 3, 4, 6, 7, 8, 9, kSectionCount};
/// Bytes of one gripper before its particles: id, max force, two poses of 7 doubles, start time, duration,
/// the frame name's length and the particle count.
constexpr std::size_t kGripperFixedBytes = 4 + 8 + 2 * 7 * 8 + 8 + 8 + 8 + 8;
/// Bytes per held particle: its index and its offset.
constexpr std::size_t kGripperBytesPerParticle = 4 + 3 * 8;
/// Most grippers a file may hold (Simulation::kMaxGrippers is checked when it is restored).
constexpr std::size_t kMaxGrippersInFile = 1024;
/// Bytes of one frame collider's track: seen (uint8), two poses of 7 doubles, start time, duration.
constexpr std::size_t kLinkTrackBytes = 1 + 2 * 7 * 8 + 8 + 8;
/// Most frame colliders a file may pose (the options' list is checked against it when it is restored).
constexpr std::size_t kMaxLinksInFile = 4096;
constexpr std::size_t kTagBytes = sizeof(kOptionsTag);
/// Longest excerpt of a validation problem quoted in an error (it may hold a string from the file).
constexpr std::size_t kMaxExcerptChars = 80;
/// Doubles per particle in the state section: positions and velocities, 3 each.
constexpr std::size_t kStateDoublesPerParticle = 6;
constexpr std::size_t kMaxParticles =
    static_cast<std::size_t>(OptionLimits::kMaxGridSide) * static_cast<std::size_t>(OptionLimits::kMaxGridSide);

std::string excerpt(const std::string& text) {
  return text.size() <= kMaxExcerptChars ? text : text.substr(0, kMaxExcerptChars) + "...";
}

// ---- Writing: native byte order (the header's mark says which) ------------------------------------

class Writer {
 public:
  template <typename T>
  void put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes_.append(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  void putBytes(const char* data, std::size_t size) { bytes_.append(data, size); }
  void putColumns(const Eigen::Matrix3Xd& values) {
    putBytes(reinterpret_cast<const char*>(values.data()), sizeof(double) * static_cast<std::size_t>(values.size()));
  }
  void putVector(const Eigen::Vector3d& v) {
    put(v.x());
    put(v.y());
    put(v.z());
  }
  void section(const char (&tag)[kTagBytes], const std::string& payload) {
    putBytes(tag, sizeof(tag));
    put(static_cast<std::uint64_t>(payload.size()));
    bytes_ += payload;
  }
  std::string& bytes() { return bytes_; }

 private:
  std::string bytes_;
};

std::string encodeState(const ClothState& state) {
  Writer out;
  out.put(static_cast<std::uint64_t>(state.particleCount()));
  out.put(state.time_s);
  out.put(state.frame);
  out.putColumns(state.positions_m);
  out.putColumns(state.velocities_m_per_s);
  return out.bytes();
}

std::string encodeInputs(const ClothInputs& inputs) {
  Writer out;
  out.putVector(inputs.wind_m_per_s);
  out.put(static_cast<std::uint64_t>(inputs.pins.size()));
  for (const int pin : inputs.pins) out.put(static_cast<std::int32_t>(pin));
  out.putColumns(inputs.pin_anchors_m);
  out.putColumns(inputs.pin_travel_m);
  out.put(static_cast<std::uint64_t>(inputs.grasps.size()));
  for (const Grasp& grasp : inputs.grasps) {
    out.put(grasp.id);
    out.put(static_cast<std::int32_t>(grasp.particle));
    out.putVector(grasp.target_m);
    out.put(grasp.stiffness_N_per_m);
    out.put(grasp.damping_N_s_per_m);
    out.putVector(grasp.extra_force_N);
  }
  return out.bytes();
}

void putPose(Writer& out, const Pose& pose) {
  out.putVector(pose.position_m);
  out.put(pose.orientation.w());
  out.put(pose.orientation.x());
  out.put(pose.orientation.y());
  out.put(pose.orientation.z());
}

std::string encodeGrippers(const std::vector<Gripper>& grippers) {
  Writer out;
  out.put(static_cast<std::uint64_t>(grippers.size()));
  for (const Gripper& gripper : grippers) {
    out.put(gripper.id);
    out.put(gripper.max_force_N);
    putPose(out, gripper.track.start);
    putPose(out, gripper.track.end);
    out.put(gripper.track.start_time_s);
    out.put(gripper.track.duration_s);
    out.put(static_cast<std::uint64_t>(gripper.frame.size()));
    out.putBytes(gripper.frame.data(), gripper.frame.size());
    out.put(static_cast<std::uint64_t>(gripper.particles.size()));
    for (const int particle : gripper.particles) out.put(static_cast<std::int32_t>(particle));
    out.putColumns(gripper.offsets_m);
  }
  return out.bytes();
}

std::string encodeLinks(const std::vector<FrameColliderTrack>& links) {
  Writer out;
  out.put(static_cast<std::uint64_t>(links.size()));
  for (const FrameColliderTrack& link : links) {
    out.put(static_cast<std::uint8_t>(link.seen ? 1 : 0));
    putPose(out, link.track.start);
    putPose(out, link.track.end);
    out.put(link.track.start_time_s);
    out.put(link.track.duration_s);
  }
  return out.bytes();
}

// ---- Reading: every read checked against what is left --------------------------------------------

/// Thrown by Reader with what was wrong; becomes the error.
struct Malformed {
  std::string reason;
};

class Reader {
 public:
  Reader(const char* data, std::size_t size, std::string what) : data_(data), size_(size), what_(std::move(what)) {}

  template <typename T>
  T get() {
    static_assert(std::is_trivially_copyable_v<T>);
    need(sizeof(T));
    T value;
    std::memcpy(&value, data_ + offset_, sizeof(T));
    offset_ += sizeof(T);
    return value;
  }
  Eigen::Vector3d getVector() {
    const double x = get<double>();
    const double y = get<double>();
    const double z = get<double>();
    return Eigen::Vector3d(x, y, z);
  }
  /// A count of items of item_bytes each that must fit in what is left (checked before allocating).
  std::size_t getCount(std::size_t item_bytes, std::size_t most, const char* item) {
    const auto count = get<std::uint64_t>();
    if (count > most || count * item_bytes > remaining()) {
      throw Malformed{what_ + ": " + std::to_string(count) + " " + item + " do not fit (at most " +
                      std::to_string(std::min<std::size_t>(most, remaining() / item_bytes)) + ")"};
    }
    return static_cast<std::size_t>(count);
  }
  Eigen::Matrix3Xd getColumns(std::size_t columns) {
    need(3 * sizeof(double) * columns);
    Eigen::Matrix3Xd values(3, static_cast<Eigen::Index>(columns));
    // An empty matrix has no storage (data() is null), and memcpy to null is undefined even for 0 bytes:
    // every pinless scene's file has an empty pin section (found by fuzz_state_file under UBSan).
    if (columns > 0) std::memcpy(values.data(), data_ + offset_, 3 * sizeof(double) * columns);
    offset_ += 3 * sizeof(double) * columns;
    return values;
  }
  std::string getBytes(std::size_t size) {
    need(size);
    std::string bytes(data_ + offset_, size);
    offset_ += size;
    return bytes;
  }
  std::size_t remaining() const { return size_ - offset_; }
  void expectEnd() const {
    if (remaining() != 0) throw Malformed{what_ + ": " + std::to_string(remaining()) + " unexpected bytes at its end"};
  }

 private:
  void need(std::size_t bytes) const {
    if (bytes > remaining()) {
      throw Malformed{what_ + ": ends early (" + std::to_string(remaining()) + " bytes left, " + std::to_string(bytes) +
                      " needed)"};
    }
  }

  const char* data_;
  std::size_t size_;
  std::string what_;
  std::size_t offset_ = 0;
};

SceneOptions decodeOptions(const std::string& text) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception&) {
    throw Malformed{"options section: not valid YAML"};
  }
  SceneOptions options;
  std::vector<std::string> errors;
  if (!applySceneYaml(root, "options section", &options, &errors)) {
    throw Malformed{"options section: " + std::to_string(errors.size()) + " keys or values are not scene options"};
  }
  const std::vector<std::string> problems = validateSceneOptions(options);
  if (!problems.empty()) throw Malformed{"options section: invalid options: " + excerpt(problems.front())};
  return options;
}

ClothState decodeState(const std::string& bytes) {
  Reader in(bytes.data(), bytes.size(), "state section");
  ClothState state;
  const std::size_t count = in.getCount(kStateDoublesPerParticle * sizeof(double), kMaxParticles, "particles");
  state.time_s = in.get<double>();
  state.frame = in.get<std::uint64_t>();
  if (count * kStateDoublesPerParticle * sizeof(double) != in.remaining()) {
    throw Malformed{"state section: " + std::to_string(in.remaining()) + " bytes of arrays for " +
                    std::to_string(count) + " particles"};
  }
  state.positions_m = in.getColumns(count);
  state.velocities_m_per_s = in.getColumns(count);
  in.expectEnd();
  return state;
}

ClothInputs decodeInputs(const std::string& bytes) {
  Reader in(bytes.data(), bytes.size(), "inputs section");
  ClothInputs inputs;
  inputs.wind_m_per_s = in.getVector();
  constexpr std::size_t kPinBytes = sizeof(std::int32_t) + 2 * 3 * sizeof(double);
  const std::size_t pins = in.getCount(kPinBytes, kMaxParticles, "pins");
  for (std::size_t p = 0; p < pins; ++p) inputs.pins.push_back(in.get<std::int32_t>());
  inputs.pin_anchors_m = in.getColumns(pins);
  inputs.pin_travel_m = in.getColumns(pins);
  constexpr std::size_t kGraspBytes = sizeof(std::uint32_t) + sizeof(std::int32_t) + 8 * sizeof(double);
  // More than the simulation allows still parses here; Simulation::restore names the limit.
  constexpr std::size_t kMostGraspsParsed = 1024;
  const std::size_t grasps = in.getCount(kGraspBytes, kMostGraspsParsed, "grasps");
  for (std::size_t g = 0; g < grasps; ++g) {
    Grasp grasp;
    grasp.id = in.get<std::uint32_t>();
    grasp.particle = in.get<std::int32_t>();
    grasp.target_m = in.getVector();
    grasp.stiffness_N_per_m = in.get<double>();
    grasp.damping_N_s_per_m = in.get<double>();
    grasp.extra_force_N = in.getVector();
    inputs.grasps.push_back(grasp);
  }
  in.expectEnd();
  return inputs;
}

std::string encodeMotion(const GuardMemory& guard) {
  Writer out;
  out.put(guard.frame_motion_m_per_s);
  return out.bytes();
}

std::string encodeSleep(const GuardMemory& guard) {
  Writer out;
  out.put(static_cast<std::int32_t>(guard.calm_frames));
  out.put(guard.drive_fingerprint);
  return out.bytes();
}

std::string encodeLast(int last_frame_substeps) {
  Writer out;
  out.put(static_cast<std::int32_t>(last_frame_substeps));
  return out.bytes();
}

std::string encodeAnchor(const GuardMemory& guard) {
  Writer out;
  out.put(guard.calm_largest_step_m);
  out.put(static_cast<std::uint64_t>(guard.calm_anchor_m.cols()));
  out.putColumns(guard.calm_anchor_m);
  return out.bytes();
}

std::string encodeGuard(const GuardMemory& guard) {
  Writer out;
  out.put(static_cast<std::int32_t>(guard.auto_scale));
  out.put(static_cast<std::int32_t>(guard.consecutive_rollbacks));
  return out.bytes();
}

Pose getPose(Reader& in) {
  Pose pose;
  pose.position_m = in.getVector();
  const double w = in.get<double>();
  const double x = in.get<double>();
  const double y = in.get<double>();
  const double z = in.get<double>();
  pose.orientation = Eigen::Quaterniond(w, x, y, z);
  return pose;
}

std::vector<Gripper> decodeGrippers(const std::string& bytes) {
  Reader in(bytes.data(), bytes.size(), "grippers section");
  std::vector<Gripper> grippers(in.getCount(kGripperFixedBytes, kMaxGrippersInFile, "grippers"));
  for (Gripper& gripper : grippers) {
    gripper.id = in.get<std::uint32_t>();
    gripper.max_force_N = in.get<double>();
    gripper.track.start = getPose(in);
    gripper.track.end = getPose(in);
    gripper.track.start_time_s = in.get<double>();
    gripper.track.duration_s = in.get<double>();
    gripper.frame = in.getBytes(in.getCount(1, OptionLimits::kMaxTextChars, "characters of a frame name"));
    const std::size_t count = in.getCount(kGripperBytesPerParticle, kMaxParticles, "held particles");
    gripper.particles.resize(count);
    for (int& particle : gripper.particles) particle = in.get<std::int32_t>();
    gripper.offsets_m = in.getColumns(count);
  }
  in.expectEnd();
  return grippers;
}

std::vector<FrameColliderTrack> decodeLinks(const std::string& bytes) {
  Reader in(bytes.data(), bytes.size(), "frame colliders section");
  std::vector<FrameColliderTrack> links(in.getCount(kLinkTrackBytes, kMaxLinksInFile, "frame colliders"));
  for (FrameColliderTrack& link : links) {
    const auto seen = in.get<std::uint8_t>();
    if (seen > 1) throw Malformed{"frame colliders section: a seen flag is neither 0 nor 1"};
    link.seen = seen == 1;
    link.track.start = getPose(in);
    link.track.end = getPose(in);
    link.track.start_time_s = in.get<double>();
    link.track.duration_s = in.get<double>();
  }
  in.expectEnd();
  return links;
}

double decodeMotion(const std::string& bytes) {
  Reader in(bytes.data(), bytes.size(), "motion section");
  const auto motion_m_per_s = in.get<double>();
  in.expectEnd();
  return motion_m_per_s;
}

void decodeSleep(const std::string& bytes, GuardMemory* guard) {
  Reader in(bytes.data(), bytes.size(), "sleep section");
  guard->calm_frames = in.get<std::int32_t>();
  guard->drive_fingerprint = in.get<std::uint64_t>();
  in.expectEnd();
}

int decodeLast(const std::string& bytes) {
  Reader in(bytes.data(), bytes.size(), "last frame section");
  const auto substeps = in.get<std::int32_t>();
  in.expectEnd();
  return substeps;
}

void decodeAnchor(const std::string& bytes, GuardMemory* guard) {
  Reader in(bytes.data(), bytes.size(), "anchor section");
  guard->calm_largest_step_m = in.get<double>();
  const std::size_t count = in.getCount(3 * sizeof(double), kMaxParticles, "anchor positions");
  guard->calm_anchor_m = in.getColumns(count);
  in.expectEnd();
}

GuardMemory decodeGuard(const std::string& bytes) {
  Reader in(bytes.data(), bytes.size(), "guard section");
  GuardMemory guard;
  guard.auto_scale = in.get<std::int32_t>();
  guard.consecutive_rollbacks = in.get<std::int32_t>();
  in.expectEnd();
  return guard;
}

std::uint32_t byteSwapped(std::uint32_t value) {
  return ((value & 0xffu) << 24) | ((value & 0xff00u) << 8) | ((value >> 8) & 0xff00u) | (value >> 24);
}

std::string systemError() { return std::strerror(errno); }

}  // namespace

std::uint32_t crc32(const void* data, std::size_t size) {
  static const std::array<std::uint32_t, 256> table = [] {
    constexpr std::uint32_t kReflectedPolynomial = 0xEDB88320u;
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < t.size(); ++i) {
      std::uint32_t c = i;
      for (int bit = 0; bit < 8; ++bit) c = (c & 1u) ? kReflectedPolynomial ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  const auto* bytes = static_cast<const unsigned char*>(data);
  std::uint32_t crc = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < size; ++i) crc = table[(crc ^ bytes[i]) & 0xffu] ^ (crc >> 8);
  return crc ^ 0xFFFFFFFFu;
}

std::string encodeStateFile(const SimulationSnapshot& snapshot) {
  Writer payload;
  payload.section(kOptionsTag, sceneYaml(snapshot.options));
  payload.section(kStateTag, encodeState(snapshot.state));
  payload.section(kInputsTag, encodeInputs(snapshot.inputs));
  payload.section(kGuardTag, encodeGuard(snapshot.guard));
  payload.section(kGrippersTag, encodeGrippers(snapshot.inputs.grippers));
  payload.section(kLinksTag, encodeLinks(snapshot.inputs.frame_colliders));
  payload.section(kMotionTag, encodeMotion(snapshot.guard));
  payload.section(kSleepTag, encodeSleep(snapshot.guard));
  payload.section(kLastTag, encodeLast(snapshot.last_frame_substeps));
  payload.section(kAnchorTag, encodeAnchor(snapshot.guard));
  Writer file;
  file.putBytes(F::kMagic, sizeof(F::kMagic));
  file.put(F::kByteOrderMark);
  file.put(F::kVersion);
  file.put(static_cast<std::uint64_t>(payload.bytes().size()));
  file.put(crc32(payload.bytes().data(), payload.bytes().size()));
  file.put(std::uint32_t{0});  // reserved, 0 in version 1
  static_assert(sizeof(F::kMagic) + 4 + 4 + 8 + 4 + 4 == F::kHeaderBytes, "the header's fields fill kHeaderBytes");
  file.bytes() += payload.bytes();
  return std::move(file.bytes());
}

bool decodeStateFile(const std::string& bytes, SimulationSnapshot* snapshot, std::string* error) {
  try {
    if (bytes.size() < F::kHeaderBytes) {
      throw Malformed{"truncated: " + std::to_string(bytes.size()) + " bytes, shorter than the " +
                      std::to_string(F::kHeaderBytes) + "-byte header"};
    }
    if (std::memcmp(bytes.data(), F::kMagic, sizeof(F::kMagic)) != 0) {
      throw Malformed{"not a cloth_sim state file (its first 8 bytes are not CLOTHSAV)"};
    }
    Reader header(bytes.data() + sizeof(F::kMagic), F::kHeaderBytes - sizeof(F::kMagic), "header");
    const auto mark = header.get<std::uint32_t>();
    if (mark != F::kByteOrderMark) {
      throw Malformed{mark == byteSwapped(F::kByteOrderMark)
                          ? "written on a machine of the other byte order; this build reads only its own"
                          : "corrupted header (bad byte-order mark)"};
    }
    const auto version = header.get<std::uint32_t>();
    if (version < 1 || version > F::kVersion) {
      throw Malformed{"version " + std::to_string(version) + " is not supported (this build reads versions 1 to " +
                      std::to_string(F::kVersion) + ")"};
    }
    const auto payload_bytes = header.get<std::uint64_t>();
    const auto checksum = header.get<std::uint32_t>();
    const std::size_t held = bytes.size() - F::kHeaderBytes;
    if (payload_bytes > held) {
      throw Malformed{"truncated: the header announces " + std::to_string(payload_bytes) + " bytes of payload, the file holds " +
                      std::to_string(held)};
    }
    if (payload_bytes < held) {
      throw Malformed{"corrupted: " + std::to_string(held - payload_bytes) + " bytes after the announced payload"};
    }
    const char* payload = bytes.data() + F::kHeaderBytes;
    if (crc32(payload, held) != checksum) throw Malformed{"corrupted: the payload's CRC-32 does not match the header's"};

    Reader sections(payload, held, "payload");
    std::array<std::string, kSectionCount> parts;
    const std::array<const char*, kSectionCount> tags{kOptionsTag, kStateTag, kInputsTag, kGuardTag, kGrippersTag,
                                                      kLinksTag, kMotionTag, kSleepTag, kLastTag, kAnchorTag};
    const std::size_t section_count = kSectionsInVersion[version];
    for (std::size_t s = 0; s < section_count; ++s) {
      const std::string expected(tags[s], kTagBytes);
      if (sections.getBytes(kTagBytes) != expected) {
        throw Malformed{"corrupted: section " + std::to_string(s + 1) + " is not the expected " + expected};
      }
      const auto length = sections.get<std::uint64_t>();
      if (length > sections.remaining()) throw Malformed{"corrupted: section " + expected + " is longer than the payload"};
      parts[s] = sections.getBytes(static_cast<std::size_t>(length));
    }
    sections.expectEnd();

    SimulationSnapshot read;
    read.options = decodeOptions(parts[0]);
    read.state = decodeState(parts[1]);
    read.inputs = decodeInputs(parts[2]);
    if (version >= 2) read.guard = decodeGuard(parts[3]);
    if (version >= 3) {
      read.inputs.grippers = decodeGrippers(parts[4]);
      read.inputs.frame_colliders = decodeLinks(parts[5]);
    } else {
      read.inputs.frame_colliders.resize(read.options.colliders.frames.size());  // older files have none
    }
    if (version >= 4) read.guard.frame_motion_m_per_s = decodeMotion(parts[6]);
    if (version >= 5) decodeSleep(parts[7], &read.guard);
    if (version >= 6) read.last_frame_substeps = decodeLast(parts[8]);
    if (version >= 7) {
      decodeAnchor(parts[9], &read.guard);
    } else if (read.guard.calm_frames > 0) {
      // Older files counted calm frames frame to frame, with no anchor: one that was calm is seen at rest
      // from where it was saved, each frame of its rest within sleep_speed (a largest step of 0).
      read.guard.calm_anchor_m = read.state.positions_m;
    }
    const int particles = read.options.rows * read.options.cols;
    if (read.state.particleCount() != particles) {
      throw Malformed{"state section: " + std::to_string(read.state.particleCount()) + " particles for a " +
                      std::to_string(read.options.rows) + "x" + std::to_string(read.options.cols) + " grid"};
    }
    *snapshot = std::move(read);
    return true;
  } catch (const Malformed& malformed) {
    *error = malformed.reason;
    return false;
  }
}

bool writeStateFile(const std::string& path, const SimulationSnapshot& snapshot, std::string* error) {
  if (path.empty()) {
    *error = "no path given";
    return false;
  }
  // What the path is, before anything opens it (lstat: a link is not followed): opening a FIFO blocked
  // the node until something wrote to it. Any ROS peer may ask for a save: replace only state files, so
  // a mistyped or hostile path cannot destroy another file the node can write.
  std::string lookup_error;
  switch (pathKind(path, &lookup_error)) {
    case PathKind::kAbsent:
      break;
    case PathKind::kUnreachable:
      *error = "cannot write " + path + ": " + lookup_error;
      return false;
    case PathKind::kDirectory:
      *error = path + " is a directory";
      return false;
    case PathKind::kOther:
      *error = path + " exists and is not a regular file (a link, FIFO, device or socket): not replaced";
      return false;
    case PathKind::kRegularFile: {
      // Its magic, read non-blocking as every file a request names.
      std::string existing;
      std::string ignored;
      if (!readRegularFileStart(path, sizeof(F::kMagic), &existing, &ignored) || existing.size() < sizeof(F::kMagic) ||
          std::memcmp(existing.data(), F::kMagic, sizeof(F::kMagic)) != 0) {
        *error = path + " exists and is not a cloth_sim state file: not replaced";
        return false;
      }
      break;
    }
  }
  const std::string bytes = encodeStateFile(snapshot);
  // A temporary file next to the target, renamed over it once complete: rename within one file system
  // is atomic, so readers see the old file or the new one, never a half-written one.
  // Named for this process and call; O_EXCL refuses a name that exists. Mode 0666 less the umask, as
  // any file the user writes.
  static std::atomic<unsigned> saves{0};
  const std::string temporary = path + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(saves++);
  constexpr mode_t kFileMode = 0666;
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, kFileMode);
  if (fd < 0) {
    *error = "cannot create a file next to " + path + ": " + systemError();
    return false;
  }
  std::size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    written += static_cast<std::size_t>(n);
  }
  std::string failure;
  if (written != bytes.size()) failure = "cannot write " + path + ": " + systemError();
  if (failure.empty() && ::fsync(fd) != 0) failure = "cannot flush " + path + ": " + systemError();
  if (::close(fd) != 0 && failure.empty()) failure = "cannot close " + path + ": " + systemError();
  if (failure.empty() && std::rename(temporary.c_str(), path.c_str()) != 0) {
    failure = "cannot rename the written file to " + path + ": " + systemError();
  }
  if (!failure.empty()) {
    std::remove(temporary.c_str());
    *error = failure;
    return false;
  }
  return true;
}

bool readStateFile(const std::string& path, SimulationSnapshot* snapshot, std::string* error) {
  if (path.empty()) {
    *error = "no path given";
    return false;
  }
  std::string bytes;
  std::string read_error;
  if (!readBoundedRegularFile(path, F::kMaxFileBytes, &bytes, &read_error)) {
    *error = path + ": " + read_error + (read_error.find("larger than") != std::string::npos
                                             ? " (more than a state file of the largest grid can hold)"
                                             : "");
    return false;
  }
  std::string reason;
  if (!decodeStateFile(bytes, snapshot, &reason)) {
    *error = path + ": " + reason;
    return false;
  }
  return true;
}

}  // namespace cloth_sim::core
