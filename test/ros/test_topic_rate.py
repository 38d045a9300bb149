#!/usr/bin/python3
"""cloth_topic_rate, the README's rate meter, reports the header stamps' rate of ClothState and Marker.

Both definitions start with comment lines before their Header; the tool looked only at the first line
and never reported stamp_rate_hz for either. Runs the installed tool against the node of
test/ros/topic_rate.test (the hanging scene at 8 x 8, 50 Hz) and reads its JSON line. Also: an invalid
topic name and an infinite duration are refused (exit 2) instead of aborting or never ending.
"""
import json
import subprocess
import unittest

import rostest

FRAME_RATE_HZ = 50.0
# The stamps are the frames' own times: exactly the frame rate for ~state unless frames were dropped (a
# loaded machine), and for ~mesh unless a late timer tick caught up frames and sent one mesh for them, so a
# wide margin below and a narrow one above.
LOWEST_STAMP_RATE_HZ = 20.0
HIGHEST_STAMP_RATE_HZ = 51.0
TOPICS = ["/cloth_node/state", "/cloth_node/mesh"]
# The tools' exit status for a bad command line (tool_common.h's kExitUsage).
EXIT_USAGE = 2
# Long enough for a refusal, which comes before anything is subscribed; a run that is not refused would
# wait far longer (an infinite --wait never ended).
REFUSAL_TIMEOUT_S = 30


class TopicRate(unittest.TestCase):
    def test_the_stamp_rate_of_state_and_mesh_is_reported(self):
        result = subprocess.run(["rosrun", "cloth_sim", "cloth_topic_rate", "--seconds", "2", "--skip", "0.5",
                                 "--wait", "30", "--queue", "6"] + TOPICS,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=120, check=False)
        self.assertEqual(result.returncode, 0, result.stderr.decode(errors="replace")[-2000:])
        report = json.loads(result.stdout.decode().strip().splitlines()[-1])
        for topic in TOPICS:
            measured = report["topics"][topic]
            self.assertGreater(measured["messages"], 1, topic)
            self.assertIn("stamp_rate_hz", measured, "%s: %s" % (topic, measured))
            self.assertGreater(measured["stamp_rate_hz"], LOWEST_STAMP_RATE_HZ, topic)
            self.assertLess(measured["stamp_rate_hz"], HIGHEST_STAMP_RATE_HZ, topic)

    def refused(self, arguments):
        result = subprocess.run(["rosrun", "cloth_sim", "cloth_topic_rate"] + arguments, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, timeout=REFUSAL_TIMEOUT_S, check=False)
        self.assertEqual(result.returncode, EXIT_USAGE, "%s: %s" % (arguments, result.stderr.decode(errors="replace")))
        self.assertEqual(result.stdout, b"", arguments)
        return result.stderr.decode(errors="replace")

    def test_an_invalid_topic_name_is_refused_not_aborted(self):
        # subscribe() threw ros::InvalidNameException: an abort (exit 134) instead of a message.
        # A private name (~x) passes ros::names::validate and made a NodeHandle throw; / named the root.
        # The reason is on the line before the usage (which names every flag and the tool: checked apart).
        for name, reason in (("bad name", "topic bad name:"), ("1abc", "topic 1abc:"), ("", "an empty topic name"),
                             ("~private", "topic ~private:"), ("/", "topic /: names the root namespace")):
            self.assertIn(reason, self.refused([name]).splitlines()[0], name)

    def test_an_infinite_duration_is_refused(self):
        # Only ">= 0" was checked: --wait inf never ended, --seconds inf printed "seconds": inf (not JSON).
        for flag in ["--seconds", "--wait", "--skip"]:
            self.assertIn(flag + " inf: takes a finite number", self.refused([flag, "inf", TOPICS[0]]).splitlines()[0],
                          flag)
            self.assertIn(flag + " 100000: at most 86400 s", self.refused([flag, "100000", TOPICS[0]]).splitlines()[0],
                          flag)


if __name__ == "__main__":
    rostest.rosrun("cloth_sim", "topic_rate", TopicRate)
