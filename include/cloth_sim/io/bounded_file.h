// Reading files named by a request (a scene, a texture, a state file) so that no path can block or flood
// the node: what a path is gets checked before it is opened, and every open is non-blocking. A FIFO or a
// device opened for reading waits for a writer (a FIFO texture froze the node for 629 s, a FIFO save
// target for 11 s); a /proc file or a file that grows reads without end. ROS-free.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace cloth_sim::core {

/// What is at a path, without following a final symbolic link (lstat) and without opening it.
/// kUnreachable: the lookup itself failed (a name too long, a loop of links, a folder that may not be
/// searched), with the system's message in *lookup_error where given.
enum class PathKind { kAbsent, kRegularFile, kDirectory, kOther, kUnreachable };
PathKind pathKind(const std::string& path, std::string* lookup_error = nullptr);

/// Reads at most `max_bytes` from a regular file (a link to one is followed). The file is opened
/// non-blocking and its kind and size are checked on the open descriptor (no race with a rename), and
/// the read stops after max_bytes + 1 bytes (a file that grew). False with the reason in *error ("not a
/// regular file", "N bytes: larger than the limit of M bytes", the system's message); *bytes then holds
/// nothing.
bool readBoundedRegularFile(const std::string& path, std::uintmax_t max_bytes, std::string* bytes,
                            std::string* error);

/// The first `count` bytes (fewer if the file is shorter) of a regular file, opened as above.
bool readRegularFileStart(const std::string& path, std::size_t count, std::string* bytes, std::string* error);

}  // namespace cloth_sim::core
