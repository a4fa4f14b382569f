#!/bin/sh
# Copies a handful of inputs from fuzz/corpus/TARGET (the 4 largest under 4 KB, which tend to
# reach deepest, and 2 chosen at random) into tests/fuzz_regressions/TARGET, named by content.
# Usage: fuzz/pick_regressions.sh TARGET ...
set -eu
cd "$(dirname "$0")"
for t in "$@"; do
    dest=../tests/fuzz_regressions/$t
    mkdir -p "$dest"
    { find "corpus/$t" -type f -size -4k -printf '%s %p\n' | sort -n | tail -4 | cut -d' ' -f2
      find "corpus/$t" -type f -size -4k | shuf -n 2 --random-source=/dev/zero; } |
        sort -u | while read -r f; do cp "$f" "$dest/corpus-$(basename "$f" | cut -c1-12)"; done
done
