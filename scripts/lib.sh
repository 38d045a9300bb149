# Shell helpers the scripts under scripts/ share; sourced, not run.

# require_whole_number NAME VALUE MIN [MAX]: exits 2 with a one-line message unless VALUE is a whole number
# (digits only) within [MIN, MAX] (no upper bound without MAX). "00" reads as 0: the digits are taken as a
# base-10 number before the comparison (a leading 0 would otherwise make bash read it as octal).
require_whole_number() {
  local name=$1 value=$2 min=$3 max=${4:-}
  local ok=true
  case $value in
    '' | *[!0-9]*) ok=false ;;
    *) [ "$((10#$value))" -ge "$min" ] || ok=false
       if [ -n "$max" ] && [ "$((10#$value))" -gt "$max" ]; then ok=false; fi ;;
  esac
  if ! $ok; then
    if [ -n "$max" ]; then
      echo "${0##*/}: $name must be a whole number from $min to $max, not '$value'" >&2
    else
      echo "${0##*/}: $name must be a whole number of at least $min, not '$value'" >&2
    fi
    exit 2
  fi
}

# show_launch_failure LOG [LINES]: the lines of a roslaunch log that say why it ended (a node's FATAL or
# ERROR line, roslaunch's death notice), then its last LINES lines (30): roslaunch's own status is 0 even
# when a required node died, and the log's tail is mostly roslaunch shutting down.
show_launch_failure() {
  local log=$1 lines=${2:-30}
  grep -a -E 'FATAL|ERROR|has died' "$log" >&2 || true
  echo "--- last lines of $log:" >&2
  tail -n "$lines" "$log" >&2
}
