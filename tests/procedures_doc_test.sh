#!/usr/bin/env bash
# Runs the worked examples of docs/procedures.md ("Your recording and your procedure") exactly as
# written, as a user would from the repository root: the indented command lines under "## Worked
# examples" (a line ending in '\' continues on the next), `stend` read as build/bin/stend. Every
# command must succeed, and every fit must report results (a failed or not-applicable part fails
# the test). Commands reading ../shared/data are skipped with a message where it is absent. They run
# in a scratch copy of the root (links to the sources and the build), so nothing is written into the
# work tree; nothing may be written outside runs/.
# Usage: procedures_doc_test.sh SOURCE_DIR BUILD_DIR SHARED_DATA_DIR
set -uo pipefail
src=$1 build=$2 data=$3
. "$(dirname "$0")/doc_commands.sh"
doc_scratch "$src" "$build" "$data"
commands=$(awk '/^## / {inside = ($0 == "## Worked examples")}
                inside && /^    / {
                  line = substr($0, 5)
                  cont = sub(/ *\\$/, " ", line)
                  pending = pending line
                  if (!cont) { gsub(/  +/, " ", pending); print pending; pending = "" }
                }' "$src/docs/procedures.md" | sed -E 's#^stend #build/bin/stend #')
count=$(printf '%s\n' "$commands" | grep -c 'build/bin/stend ')
if [ "$count" -lt 14 ]; then
  echo "FAIL: found only $count stend commands among the worked examples of docs/procedures.md"
  exit 1
fi
skipped=0 ran=0 unmade=""
cd "$scratch/repo"
while IFS= read -r cmd; do
  [ -n "$cmd" ] || continue
  needs_data=0
  [[ "$cmd" == *../shared/data* ]] && needs_data=1
  for run in $unmade; do [[ " $cmd " == *" $run "* ]] && needs_data=1; done
  if [ "$needs_data" = 1 ] && [ ! -d "$data" ]; then
    echo "skip  $cmd (../shared/data is absent)"
    skipped=$((skipped + 1))
    # the run folder it would have made: the commands reading it are skipped too
    [[ "$cmd" =~ -o\ ([^ ]+) ]] && unmade="$unmade ${BASH_REMATCH[1]}"
    continue
  fi
  ran=$((ran + 1))
  forbidden=""
  [[ "$cmd" == "build/bin/stend fit "* ]] && forbidden='fit failed|not applicable|results: none'
  doc_run "$cmd" "$forbidden"
done <<< "$commands"
doc_check_only_runs
echo "$((ran - failed)) of $ran worked-example commands succeeded ($skipped skipped)"
[ "$failed" -eq 0 ]
