#!/bin/bash
# Builds examples/cloth_sim_example as a downstream package would: in a workspace of its own, chained to
# the cloth_sim workspace given, with find_package(catkin REQUIRED COMPONENTS cloth_sim); then runs it.
# Writes the verdict as one JUnit test case, so make test counts it.
#
#   build_example.sh CLOTH_SIM_DEVEL_DIR EXAMPLE_WORKSPACE RESULT_XML
set -u
devel=$1 workspace=$2 result=$3
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
log=$workspace/example.log
mkdir -p "$workspace/src"
ln -sfn "$repo/examples/cloth_sim_example" "$workspace/src/cloth_sim_example"
set +u
# shellcheck disable=SC1091
source "$devel/setup.bash"
set -u
status=0
{
  cd "$workspace" && catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCMAKE_BUILD_TYPE=Release \
    && "$workspace/devel/lib/cloth_sim_example/cloth_sim_example_step"
} >"$log" 2>&1 || status=$?
tail -n 1 "$log"
failure=""
if [ "$status" != 0 ]; then
  message=$(grep -m1 -iE "error|could not find" "$log" | sed 's/&/\&amp;/g; s/</\&lt;/g; s/>/\&gt;/g; s/"/\&quot;/g')
  failure="<failure message=\"exit status $status: ${message:-see $log}\">see $log</failure>"
fi
cat >"$result" <<XML
<?xml version="1.0" encoding="UTF-8"?>
<testsuite name="example" tests="1" failures="$([ "$status" = 0 ] && echo 0 || echo 1)"><testcase classname="example" name="DownstreamPackageFindsClothSimAndStepsASimulation">$failure</testcase></testsuite>
XML
exit 0
