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
for scene in "${scenes[@]}"; do
  bag=$workdir/$scene.bag
  echo "==> pictures: $scene (${SECONDS_PER_SCENE} s)"
  roslaunch -p "$port" cloth_sim cloth.launch scene:="$scene" record:=true record_mesh:=true bag:="$bag" >"$workdir/$scene.log" 2>&1 &
  launch=$!
  sleep "$SECONDS_PER_SCENE"
  kill -INT "$launch"
  for _ in $(seq $((STOP_GRACE_S * 5))); do kill -0 "$launch" 2>/dev/null || break; sleep 0.2; done
  [ -f "$bag" ] || { echo "pictures: no bag for $scene; roslaunch said:" >&2; tail -20 "$workdir/$scene.log" >&2; exit 1; }
  "$here/rviz_screenshot.sh" "$bag" "$out_dir/rviz_$scene.png" >/dev/null
  echo "    $out_dir/rviz_$scene.png"
done
