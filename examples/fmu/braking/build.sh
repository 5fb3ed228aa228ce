#!/bin/sh
# Builds braking.fmu next to this script (Linux): braking.c compiled as
# binaries/linux64/braking.so, zipped with modelDescription.xml and resources/.
set -eu
cd "$(dirname "$0")"
${CC:-cc} -shared -fPIC -O2 -fvisibility=hidden -o braking.so braking.c -lm
python3 - <<'PY'
import zipfile
with zipfile.ZipFile("braking.fmu", "w", zipfile.ZIP_DEFLATED) as z:
    z.write("modelDescription.xml")
    z.write("braking.so", "binaries/linux64/braking.so")
    z.write("resources/friction.txt")
PY
rm braking.so
echo "wrote $(pwd)/braking.fmu"
