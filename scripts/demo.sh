#!/bin/bash
# Headless demo: run cloth.launch with recording (the mesh too: it is what gets drawn) for a few seconds,
# stop it with SIGINT (as Ctrl-C would, so rosbag closes the bag), render the last mesh to a PNG and print
# the mesh publish rate.
#
#   scripts/demo.sh WORKSPACE [SCENE] [SECONDS] [OUTDIR]
#
# WORKSPACE is a built catkin workspace holding cloth_sim (its devel/setup.bash is sourced). The ROS
# master runs on a free port of its own, so a demo never talks to another roscore on this machine.
set -eu -o pipefail

ws=${1:?usage: demo.sh WORKSPACE [SCENE] [SECONDS] [OUTDIR]}
scene=${2:-drape}
seconds=${3:-10}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=lib.sh
source "$here/lib.sh"
# timeout(1) reads 0 as "no limit": the demo would record a bag until the disk is full. So a whole number
# above 0, checked before anything starts.
require_whole_number SECONDS "$seconds" 1
robot_seconds=14  # the least the robot demo runs (wall time, start-up included)
fold_seconds=12   # the least the fold demo runs: the hands let go at 2.2 s, then it settles
outdir=${4:-$here/../.build/demo}
mkdir -p "$outdir"
outdir=$(cd "$outdir" && pwd)

# Debian's ROS tools are /usr/bin/python3 scripts; a pyenv python3 earlier on PATH has no ROS modules.
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
export MPLBACKEND=Agg
export ROS_HOME=${ROS_HOME:-$ws/ros_home}
export ROS_LOG_DIR=${ROS_LOG_DIR:-$ROS_HOME/log}
if [ -z "${ROS_HOSTNAME:-}" ] && [ -z "${ROS_IP:-}" ]; then export ROS_HOSTNAME=localhost; fi
set +u
# shellcheck disable=SC1091
source "$ws/devel/setup.bash"
set -u

port=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
export ROS_MASTER_URI=http://localhost:$port

# A scene may be a path to a YAML file: name the outputs after its stem.
name=$(basename "$scene"); name=${name%.yaml}; name=${name%.yml}
bag=$outdir/$name.bag
png=$outdir/$name.png
log=$outdir/$name.launch.log
rm -f "$bag" "$bag.active" "$png"

set +e
if [ "$scene" = robot ]; then
  # The robot demo is its own launch file: the robot, its driver and the cloth (launch/robot.launch). Its
  # driver lets go at 8 s of simulated time: give the towel time to settle after that.
  launch_args=(robot.launch)
  if [ "$seconds" -lt "$robot_seconds" ]; then seconds=$robot_seconds; fi
elif [ "$scene" = fold ]; then
  # The fold demo: its driver folds the towel through ~grasp (launch/fold.launch).
  launch_args=(fold.launch)
  if [ "$seconds" -lt "$fold_seconds" ]; then seconds=$fold_seconds; fi
else
  launch_args=(cloth.launch scene:="$scene")
fi
echo "==> demo: roslaunch cloth_sim ${launch_args[*]} record:=true for ${seconds} s (master port $port)"
echo "    log: $log"
timeout -s INT -k 30 "$seconds" roslaunch -p "$port" cloth_sim "${launch_args[@]}" \
  rviz:=false record:=true record_mesh:=true bag:="$bag" >"$log" 2>&1 </dev/null
rc=$?
set -e
if [ "$rc" -ne 124 ]; then
  # 124: timeout sent SIGINT after $seconds, the expected end.
  case $rc in
    137) why="roslaunch ignored SIGINT and was killed 30 s later" ;;
    125 | 126 | 127) why="timeout could not run roslaunch" ;;
    *) why="roslaunch stopped by itself before its ${seconds} s were up: a bad launch argument, or a"
       why="$why required node that refused its scene or parameters, or died" ;;
  esac
  echo "demo: $why (status $rc); the lines of $log that say why follow" >&2
  show_launch_failure "$log"
  exit 1
fi
if grep -q "process has died" "$log"; then
  echo "demo: warning: a node died during the run:" >&2
  grep "process has died" "$log" >&2 || true
fi
if [ ! -f "$bag" ] && [ -f "$bag.active" ]; then
  echo "demo: the bag was not closed cleanly; reindexing $bag.active"
  rosbag reindex "$bag.active" >/dev/null && mv "$bag.active" "$bag"
fi
if [ ! -f "$bag" ]; then
  echo "demo: no bag at $bag; last lines of $log:" >&2
  tail -n 30 "$log" >&2
  exit 1
fi

echo "==> demo: rendering the last /cloth_node/mesh of $bag"
render_args=()
# The robot demo's towel ends lying still on the table and the forearm, the fold's on the floor: not pins.
if [ "$scene" = robot ] || [ "$scene" = fold ] || [ "$scene" = pile ]; then render_args=(--no-pins); fi
/usr/bin/python3 "$here/render_bag.py" "$bag" "$png" --title "cloth_sim: $name" "${render_args[@]}"
echo "bag: $bag"
echo "PNG: $png"
