// definitionStartsWithHeader: which message definitions cloth_topic_rate reads a stamp from.
#include "cloth_sim/ros/message_definition.h"

#include <gtest/gtest.h>

namespace {

TEST(MessageDefinition, AHeaderFirstAfterCommentsBlankLinesAndConstantsCounts) {
  EXPECT_TRUE(cloth_sim::definitionStartsWithHeader("Header header\nfloat64 x\n"));
  EXPECT_TRUE(cloth_sim::definitionStartsWithHeader("std_msgs/Header header\n"));
  EXPECT_TRUE(cloth_sim::definitionStartsWithHeader("# The cloth.\n\n  # more\nHeader header  # its frame\n"));
  EXPECT_TRUE(cloth_sim::definitionStartsWithHeader("uint8 ARROW=0\nuint8 CUBE = 1\nHeader header\n"));
  // Any spacing and any name: the bytes are the header's all the same.
  EXPECT_TRUE(cloth_sim::definitionStartsWithHeader("Header  header\n"));
  EXPECT_TRUE(cloth_sim::definitionStartsWithHeader("\tHeader\tstamp_holder"));
}

TEST(MessageDefinition, AnotherFirstFieldAnArrayOfHeadersOrNoFieldDoesNot) {
  EXPECT_FALSE(cloth_sim::definitionStartsWithHeader("float64 x\nHeader header\n"));
  EXPECT_FALSE(cloth_sim::definitionStartsWithHeader("Header[] headers\n"));
  EXPECT_FALSE(cloth_sim::definitionStartsWithHeader("Headers header\n"));
  EXPECT_FALSE(cloth_sim::definitionStartsWithHeader("# only a comment\n\n"));
  EXPECT_FALSE(cloth_sim::definitionStartsWithHeader(""));
  EXPECT_FALSE(cloth_sim::definitionStartsWithHeader("string HEADER=Header header\nfloat64 x\n"));
}

}  // namespace
