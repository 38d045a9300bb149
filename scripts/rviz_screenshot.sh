#!/usr/bin/env bash
# Renders the end of a recorded bag in rviz (config/cloth.rviz) under Xvfb and saves a screenshot.
#   scripts/rviz_screenshot.sh BAG OUT.png [SECONDS_OF_BAG_TO_PLAY]
# Needs the package built and its devel/setup.bash sourced (`make pictures` does both).
# Runs its own roscore on a free port and its own X display, so it does not disturb a running ROS system.
set -euo pipefail
bag=$1
out=$2
tail_s=${3:-2}
export PATH=/usr/bin:$PATH
export LIBGL_ALWAYS_SOFTWARE=1
readonly RVIZ_START_S=10    # rviz with software GL takes a few seconds to show its first frame
readonly SETTLE_S=2         # let rviz draw the last message before the screenshot
readonly VIEW_CROP=620x628+364+62  # rviz's 3D view inside the 1000x720 screen (WxH+X+Y, pixels)

display=:$((90 + RANDOM % 100))
port=$((20000 + RANDOM % 20000))
export ROS_MASTER_URI=http://localhost:$port DISPLAY=$display
workdir=$(mktemp -d)
export ROS_HOME=$workdir
pids=()
cleanup() { for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done; wait 2>/dev/null || true; rm -rf "$workdir"; }
trap cleanup EXIT

Xvfb "$display" -screen 0 1000x720x24 >"$workdir/xvfb.log" 2>&1 & pids+=($!)
roscore -p "$port" >"$workdir/roscore.log" 2>&1 & pids+=($!)
for _ in $(seq 50); do rosparam list >/dev/null 2>&1 && break; sleep 0.2; done
rosparam set use_sim_time true
# A recording holds no static tf: cloth_viewer puts the fixed frame (world, under map) in tf, as
# playback.launch does, so rviz's Global Status is OK.
rosrun cloth_sim cloth_viewer _publish_mesh:=false _frame_id:=world _parent_frame_id:=map >"$workdir/viewer.log" 2>&1 & pids+=($!)
rviz -d "$(rospack find cloth_sim)/config/cloth.rviz" >"$workdir/rviz.log" 2>&1 & pids+=($!)
sleep "$RVIZ_START_S"
duration=$(python3 -c "import rosbag,sys; b=rosbag.Bag(sys.argv[1]); print(b.get_end_time()-b.get_start_time())" "$bag")
start=$(python3 -c "print(max(0.0, $duration - $tail_s))")
rosbag play --clock --quiet -s "$start" "$bag" >"$workdir/play.log" 2>&1
sleep "$SETTLE_S"
# Keep only rviz's 3D view: the window is 1000x720 at the screen's corner with its docks on the left.
import -window root -display "$display" -crop "$VIEW_CROP" +repage "$out"
echo "$out"
