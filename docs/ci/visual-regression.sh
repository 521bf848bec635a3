#!/bin/sh
# visual-regression.sh: convert the art, compare the renders with the committed baseline.
#   sh visual-regression.sh            compare: exit 0 same, 1 changed, 2 could not compare
#   sh visual-regression.sh --approve  make this build's renders the baseline (then commit it)
# From depixel's docs/ci/visual-regression.sh (docs/ci.md).
set -eu
ART=${ART:-art}                       # the pixel art (PNG, GIF, ...), subfolders included
BASELINE=${BASELINE:-renders}         # the approved renders, committed
BUILD=${BUILD:-build}                 # this build's renders and reports (not committed)

# --force: every render is this build's; --prune: a deleted sprite's render goes too, so a
# build folder kept between runs reports it missing
depixel convert "$ART" -r --out-dir "$BUILD/renders" --force --prune -q
mkdir -p "$BASELINE"
if [ "${1:-}" = "--approve" ]; then
    depixel diff "$BASELINE" "$BUILD/renders" --scale 2 --update --prune
    echo "baseline updated: commit $BASELINE"
    exit 0
fi
status=0
depixel diff "$BASELINE" "$BUILD/renders" --scale 2 \
    --html "$BUILD/diff-report" --junit "$BUILD/diff.xml" || status=$?
if [ "$status" -ne 0 ]; then
    echo "renders changed: open $BUILD/diff-report/index.html;" \
         "if the change is right, run: sh visual-regression.sh --approve" >&2
fi
exit "$status"
