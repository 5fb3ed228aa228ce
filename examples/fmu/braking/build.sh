#!/bin/sh
# Builds braking.fmu (FMI 2.0: braking.c as binaries/linux64/braking.so) and braking3.fmu
# (FMI 3.0: braking3.c as binaries/x86_64-linux/braking.so — FMI 3.0 names platforms
# <arch>-<os>) next to this script (Linux), each zipped with its model description and
# resources/.
set -eu
cd "$(dirname "$0")"
arch="$(uname -m)"
${CC:-cc} -shared -fPIC -O2 -fvisibility=hidden -o braking.so braking.c -lm
${CC:-cc} -shared -fPIC -O2 -fvisibility=hidden -o braking3.so braking3.c -lm
ARCH="$arch" python3 - <<'PY'
import os, zipfile
for fmu, xml, lib, folder in [
    ("braking.fmu", "modelDescription.xml", "braking.so", "linux64"),
    ("braking3.fmu", "modelDescription3.xml", "braking3.so", os.environ["ARCH"] + "-linux"),
]:
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as z:
        z.write(xml, "modelDescription.xml")
        z.write(lib, "binaries/" + folder + "/braking.so")
        z.write("resources/friction.txt")
PY
rm braking.so braking3.so
echo "wrote $(pwd)/braking.fmu and $(pwd)/braking3.fmu"
