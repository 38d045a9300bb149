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
# The grid sides cloth_node accepts (core::OptionLimits::kMinGridSide, kMaxGridSide): anything else is refused
# by the node after roslaunch has started, and the rate tool then waits for messages that never come.
readonly MIN_SIDE=2 MAX_SIDE=512
case $n in
  '' | *[!0-9]*) n_ok=false ;;
  *) n_ok=true; { [ "$((10#$n))" -ge "$MIN_SIDE" ] && [ "$((10#$n))" -le "$MAX_SIDE" ]; } || n_ok=false ;;
esac
if ! $n_ok; then
  echo "fold_rate.sh: N must be a whole number from $MIN_SIDE to $MAX_SIDE (the node's grid sides), not '$n'" >&2
  exit 2
fi
case $seconds in
  '' | *[!0-9]*) seconds_ok=false ;;
  *) seconds_ok=true; [ "$((10#$seconds))" -gt 0 ] || seconds_ok=false ;;  # "00" is 0 too
esac
if ! $seconds_ok; then echo "fold_rate.sh: SECONDS must be a whole number above 0, not '$seconds'" >&2; exit 2; fi
skip=${SKIP:-0}
case $skip in
  '' | *[!0-9]*) echo "fold_rate.sh: SKIP must be a whole number of seconds, not '$skip'" >&2; exit 2 ;;
esac
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
  echo "fold_rate.sh: roslaunch exited early; the lines that say why (the whole log: $log):" >&2
  grep -a -E 'FATAL|ERROR|has died' "$log" >&2 || tail -n 10 "$log" >&2
  exit 1
fi
kill -INT "$launch"
wait "$launch"
echo "roslaunch log: $log"
exit "$status"
