#!/usr/bin/env bash
# Stands in for one command while help2man makes its man page (cmake/install.cmake runs
# help2man on a wrapper named after the page, which calls this):
#   man.sh PAGE VERSION TOOL [COMMAND] ARGS...
# --version prints "PAGE (vdbscatter) VERSION", which names the page (the commands have no
# --version of their own); --help prints TOOL [COMMAND] --help with its usage lines in the
# form help2man reads as the SYNOPSIS ("Usage:", further forms as "or:", wrapped arguments
# joined); anything else runs TOOL [COMMAND] ARGS.
set -euo pipefail
if [ $# -lt 3 ]; then
  echo "usage: scripts/man.sh PAGE VERSION TOOL [COMMAND] ARGS..." >&2
  exit 2
fi
page=$1 version=$2 tool=$3
shift 3
command=()
if [ $# -gt 0 ] && [ "${1#-}" = "$1" ]; then
  command=("$1")
  shift
fi

case "${1:-}" in
  --version)
    if [ ${#command[@]} -eq 0 ] && [ "$page" = vdbscatter ]; then
      echo "vdbscatter $version"
    else
      echo "$page (vdbscatter) $version"
    fi
    ;;
  --help)
    help=$("$tool" "${command[@]}" --help)
    # The usage block runs from line 1 to the first empty line.
    awk '
      usage && /^$/ { print line; print; usage = 0; next }
      NR == 1 { line = $0; sub(/^usage:/, "Usage:", line); usage = 1; next }
      usage && /^[ \t]+vdbscatter/ { print line; line = $0; sub(/^[ \t]+/, "  or:  ", line); next }
      usage { more = $0; sub(/^[ \t]+/, " ", more); line = line more; next }
      { print }
      END { if (usage) print line }' <<<"$help"
    ;;
  *)
    exec "$tool" "${command[@]}" "$@"
    ;;
esac
