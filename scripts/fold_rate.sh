#!/bin/bash
# The node's ~state rate while the fold demo folds (issue 15): launch/fold.launch at N x N on a master of
# its own, ~state counted by the C++ cloth_topic_rate over SECONDS from the first message, or from SKIP
# seconds after it (the fold itself takes 2.2 s of simulated time, then the towel settles).
#
#   scripts/fold_rate.sh WORKSPACE N [SECONDS]
#   SKIP=S scripts/fold_rate.sh WORKSPACE N [SECONDS]   # count from S s after the first message (the towel at rest)
#
# WORKSPACE is a built catkin workspace holding cloth_sim (make build prints it).
ws=${1:?usage: fold_rate.sh WORKSPACE N [SECONDS]}
n=${2:?usage: fold_rate.sh WORKSPACE N [SECONDS]}
seconds=${3:-8}
# shellcheck source=lib.sh
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
# The grid sides cloth_node accepts (core::OptionLimits::kMinGridSide, kMaxGridSide): anything else is refused
# by the node after roslaunch has started, and the rate tool then waits for messages that never come.
readonly MIN_SIDE=2 MAX_SIDE=512
require_whole_number N "$n" "$MIN_SIDE" "$MAX_SIDE"
require_whole_number SECONDS "$seconds" 1
skip=${SKIP:-0}
require_whole_number SKIP "$skip" 0
# Debian's ROS tools are /usr/bin/python3 scripts; a pyenv python3 earlier on PATH has no ROS modules.
export PATH=/usr/bin:/bin:$PATH
export ROS_HOME=${ROS_HOME:-$ws/ros_home}
# shellcheck disable=SC1091
source "$ws/devel/setup.bash"
port=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
export ROS_MASTER_URI=http://localhost:$port ROS_HOSTNAME=localhost
log=$(mktemp /tmp/fold_rate.XXXXXX.log)
roslaunch -p "$port" cloth_sim fold.launch rows:="$n" cols:="$n" >"$log" 2>&1 </dev/null &
launch=$!
# The rate tool waits for a master without end: a launch that fails (a workspace without the package)
# must not hang the script, so it gets the measurement's time and a minute more.
status=0
# A queue of 6, the node's own: the frames a late tick catches up on arrive back to back.
timeout $((skip + seconds + 60)) "$ws/devel/lib/cloth_sim/cloth_topic_rate" --wait 20 --skip "$skip" --seconds "$seconds" --queue 6 \
  /cloth_node/state || status=$?
if ! kill -0 "$launch" 2>/dev/null; then
  # A required node that refused its parameters or died ends roslaunch: its FATAL line and the death notice
  # say which and why (the log's last lines are only roslaunch shutting down).
  echo "fold_rate.sh: roslaunch exited early; the lines that say why:" >&2
  show_launch_failure "$log" 10
  exit 1
fi
kill -INT "$launch"
wait "$launch"
echo "roslaunch log: $log"
exit "$status"
