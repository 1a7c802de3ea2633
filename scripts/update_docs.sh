#!/usr/bin/env bash
# Rewrites the generated part of docs/experiment-file.md (the key tables) from the registries:
# `dsnake schema --markdown` between the BEGIN/END markers. The test suite fails until it is run
# after an options change (tests/schema/test_schema.py).
set -euo pipefail
cd "$(dirname "$0")/.."
exe=${DSNAKE:-build/release/experiments/dsnake}
doc=docs/experiment-file.md
python3 - "$exe" "$doc" <<'PY'
import subprocess, sys
exe, doc = sys.argv[1], sys.argv[2]
begin, end = "<!-- BEGIN GENERATED: dsnake schema --markdown -->\n", "<!-- END GENERATED -->\n"
text = open(doc).read()
head, rest = text.split(begin, 1)
tail = rest.split(end, 1)[1]
generated = subprocess.run([exe, "schema", "--markdown"], check=True, capture_output=True, text=True).stdout
open(doc + ".tmp", "w").write(head + begin + generated + end + tail)
PY
mv "$doc.tmp" "$doc"
echo "update_docs: rewrote the generated tables of $doc"
