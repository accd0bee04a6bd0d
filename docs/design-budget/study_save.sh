#!/usr/bin/env bash
# Copies a convergence study's state (docs/design.md, "The 10x study in parts") into a folder meant for
# the repository: summaries, logs, each library's manifest, lens files, checkpoint and round trace, but
# no layout pictures (a resumed library does not need them) and no half-written `.part` summaries. Pause
# or stop the study first (pgrep -f "unicac design" | xargs -r kill -STOP), so that every library's files
# come from one moment.
#
#   bash docs/design-budget/study_save.sh OUT DEST     # e.g. /work/study-30M docs/design-budget/study-30M
set -euo pipefail
out=${1:?usage: study_save.sh OUT DEST}
dest=${2:?usage: study_save.sh OUT DEST}
[ -d "$out" ] || { echo "study_save.sh: no study folder at $out" >&2; exit 2; }
case $(realpath -m "$dest")/ in "$(realpath "$out")"/*) echo "study_save.sh: DEST must not lie inside OUT" >&2; exit 2 ;; esac
case $(realpath "$out")/ in "$(realpath -m "$dest")"/*) echo "study_save.sh: OUT must not lie inside DEST" >&2; exit 2 ;; esac
# DEST is replaced whole, so it must be absent or an earlier save (which carries this marker).
marker=.study_save
if [ -e "$dest" ] && [ ! -f "$dest/$marker" ]; then
  echo "study_save.sh: $dest exists and is not an earlier study save (no $marker in it); choose another DEST" >&2
  exit 2
fi
parent=$(dirname "$(realpath -m "$dest")")
mkdir -p "$parent"
tmp=$(mktemp -d "$parent/.study_save.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
(cd "$out" && tar cf - --exclude='*.png' --exclude='*.part' --exclude="$marker" .) | (cd "$tmp" && tar xf -)
echo "a study's state saved by docs/design-budget/study_save.sh from $out" > "$tmp/$marker"
rm -rf "$dest"
mv "$tmp" "$dest"
trap - EXIT
echo "study_save.sh: $(find "$dest" -type f | wc -l) files, $(du -sh "$dest" | cut -f1) in $dest"
