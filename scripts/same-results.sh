#!/usr/bin/env bash
# Behaviour check for refactors: runs every study in studies/ with two builds of `lab` and diffs
# their results.json (and report-data.json) with the fields that carry times left out.
#
#   scripts/same-results.sh OLD NEW [STUDY.yaml ...]
#
# OLD and NEW are each a `lab` executable or a git ref (exported with `git archive` and built with
# `$CARGO build --release --bin lab`; set CARGO="flock /work/.buildlock cargo" on a shared machine,
# CARGO_TARGET_DIR is honoured). Studies default to studies/*.yaml. Both builds run the study files
# of this working tree, each into its own temp directory, with a PATH of system directories only:
# crushsim is never found, so the honeycomb studies replay their fixtures. Studies that need a
# program which is not installed (ccx) are skipped and listed. Exit 0 when every compared file is
# identical, 1 otherwise.
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 2 ] || { sed -n '2,13p' "$0"; exit 2; }
old=$1 new=$2
shift 2
studies=("$@")
[ ${#studies[@]} -gt 0 ] || studies=(studies/*.yaml)
tmp=$(mktemp -d /tmp/same-results.XXXXXX)
trap 'rm -rf "$tmp"' EXIT

# A `lab` executable for OLD or NEW (an executable path, or a git ref built in $tmp).
lab_of() {
    local what=$1 name=$2
    if [ -x "$what" ] && [ -f "$what" ]; then
        realpath "$what"
        return
    fi
    local src="$tmp/src-$name"
    mkdir -p "$src"
    git archive "$what" | tar -x -C "$src"
    (cd "$src" && ${CARGO:-cargo} build --release --quiet --bin lab) >&2
    echo "${CARGO_TARGET_DIR:-$src/target}/release/lab"
}

# Leaves out the keys that carry times (wall_time_s, *_ms, seconds), recursively, and writes the
# output directory ($2, different per side) as OUT in strings; the rest is compared byte for byte.
strip_times() {
    python3 - "$1" "$2" <<'EOF'
import json, re, sys
TIME = re.compile(r"(^wall_time|_ms$|seconds$|^elapsed|^duration)")
def strip(v):
    if isinstance(v, dict):
        return {k: strip(x) for k, x in v.items() if not TIME.search(k)}
    if isinstance(v, list):
        return [strip(x) for x in v]
    if isinstance(v, str):
        return v.replace(sys.argv[2], "OUT")
    return v
with open(sys.argv[1]) as f:
    print(json.dumps(strip(json.load(f)), indent=1, sort_keys=False))
EOF
}

old_lab=$(lab_of "$old" old)
cp "$old_lab" "$tmp/lab-old"
new_lab=$(lab_of "$new" new)
cp "$new_lab" "$tmp/lab-new"

status=0
for study in "${studies[@]}"; do
    name=$(basename "$study" .yaml)
    if grep -q 'adapter: calculix' "$study" && ! command -v ccx >/dev/null; then
        echo "skip  $name (needs ccx)"
        continue
    fi
    for side in old new; do
        PATH=/usr/local/bin:/usr/bin:/bin "$tmp/lab-$side" run "$study" --out "$tmp/$side/$name" \
            >"$tmp/$side-$name.stdout" 2>"$tmp/$side-$name.stderr" || echo $? >"$tmp/$side-$name.rc"
    done
    rc_old=$(cat "$tmp/old-$name.rc" 2>/dev/null || echo 0)
    rc_new=$(cat "$tmp/new-$name.rc" 2>/dev/null || echo 0)
    verdict="same"
    [ "$rc_old" = "$rc_new" ] || { verdict="DIFFERENT exit codes ($rc_old, $rc_new)"; status=1; }
    for file in results.json report-data.json; do
        a="$tmp/old/$name/$file" b="$tmp/new/$name/$file"
        if [ ! -f "$a" ] && [ ! -f "$b" ]; then continue; fi
        if [ ! -f "$a" ] || [ ! -f "$b" ]; then
            verdict="DIFFERENT ($file missing on one side)"; status=1; continue
        fi
        if ! diff <(strip_times "$a" "$tmp/old/$name") <(strip_times "$b" "$tmp/new/$name") >"$tmp/$name-$file.diff"; then
            verdict="DIFFERENT ($file)"; status=1
            head -20 "$tmp/$name-$file.diff"
        fi
    done
    echo "$verdict  $name (exit $rc_new)"
done
exit $status
