#!/usr/bin/env bash
# Records each scene through the real launch file and renders the end of each bag in rviz under Xvfb:
#   scripts/make_pictures.sh OUT_DIR [SCENE...]     (default: every built-in scene)
# Writes OUT_DIR/rviz_<scene>.png. Needs the package built and its devel/setup.bash sourced, Xvfb and
# ImageMagick's `import` (make pictures does all of that). Each scene runs SECONDS_PER_SCENE of wall time.
set -euo pipefail
out_dir=$(realpath -m "$1")
shift
export PATH=/usr/bin:$PATH
readonly SECONDS_PER_SCENE=${SECONDS_PER_SCENE:-10}
readonly STOP_GRACE_S=5    # rosbag needs a moment after SIGINT to close the bag
here=$(cd "$(dirname "$0")" && pwd)
scenes=("$@")
if [ ${#scenes[@]} -eq 0 ]; then
  for f in "$(rospack find cloth_sim)"/config/scenes/*.yaml; do scenes+=("$(basename "$f" .yaml)"); done
fi
mkdir -p "$out_dir"
workdir=$(mktemp -d)
port=$((20000 + RANDOM % 20000))
export ROS_MASTER_URI=http://localhost:$port ROS_HOME=$workdir
trap 'kill $(jobs -p) 2>/dev/null || true; rm -rf "$workdir"' EXIT
# shellcheck source=lib.sh
source "$here/lib.sh"
for scene in "${scenes[@]}"; do
  bag=$workdir/$scene.bag
  echo "==> pictures: $scene (${SECONDS_PER_SCENE} s)"
  roslaunch -p "$port" cloth_sim cloth.launch scene:="$scene" record:=true record_mesh:=true bag:="$bag" >"$workdir/$scene.log" 2>&1 &
  launch=$!
  sleep "$SECONDS_PER_SCENE"
  # roslaunch may already have ended by itself: a required node (cloth_node) refused the scene or died. Then
  # there is nothing to stop, and a bag may exist with no message in it (rosbag is closed on the way out):
  # say so with the node's FATAL line, before a failing kill under set -e ends the script (and the EXIT
  # trap deletes the log) or rviz_screenshot.sh is handed the empty bag.
  if ! kill -0 "$launch" 2>/dev/null; then
    echo "pictures: roslaunch for $scene ended by itself before its ${SECONDS_PER_SCENE} s: a required node" \
      "refused to start or died; roslaunch said:" >&2
    show_launch_failure "$workdir/$scene.log" 20
    exit 1
  fi
  kill -INT "$launch" 2>/dev/null || true  # it may still end on its own between the check and here
  for _ in $(seq $((STOP_GRACE_S * 5))); do kill -0 "$launch" 2>/dev/null || break; sleep 0.2; done
  if [ ! -f "$bag" ]; then
    echo "pictures: no bag for $scene; roslaunch said:" >&2
    show_launch_failure "$workdir/$scene.log" 20
    exit 1
  fi
  "$here/rviz_screenshot.sh" "$bag" "$out_dir/rviz_$scene.png" >/dev/null
  echo "    $out_dir/rviz_$scene.png"
done
