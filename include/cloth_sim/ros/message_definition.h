// What a ROS message definition (the text roscpp carries with every connection) says about the bytes of
// its messages, read without generated code: cloth_topic_rate measures any topic's stamps this way.
#pragma once

#include <string>

namespace cloth_sim {

/// Whether a message definition's first field is a std_msgs/Header (of any name), so that each message
/// starts with the header's bytes: uint32 seq, then the stamp. Comments, blank lines and constants (not
/// serialised: visualization_msgs/Marker declares ARROW=0 and the rest before its header) are passed
/// over; the type is the line's first word, whatever the spacing ("Header  header" too), and an array of
/// headers ("Header[] headers") is not one.
bool definitionStartsWithHeader(const std::string& definition);

}  // namespace cloth_sim
