#!/usr/bin/python3
"""cloth_topic_rate, the README's rate meter, reports the header stamps' rate of ClothState and Marker.

Both definitions start with comment lines before their Header; the tool looked only at the first line
and never reported stamp_rate_hz for either. Runs the installed tool against the node of
test/ros/topic_rate.test (the hanging scene at 8 x 8, 50 Hz) and reads its JSON line.
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


if __name__ == "__main__":
    rostest.rosrun("cloth_sim", "topic_rate", TopicRate)
