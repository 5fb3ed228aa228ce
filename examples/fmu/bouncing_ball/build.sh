#!/bin/sh
# Builds BouncingBall.fmu (FMI 2.0 co-simulation, Linux) next to this script from the Modelica
# Association's Reference FMUs, vendored unchanged in reference-fmus/ (2-Clause BSD licence,
# reference-fmus/LICENSE.txt; upstream commit in reference-fmus/README.md): the model's C source,
# the Reference FMUs' own FMI 2.0 wrapper and co-simulation solver (forward Euler at a fixed
# step of 1 ms), compiled with the system C compiler as the Reference FMUs' CMake build does
# (FMI_VERSION=2, DISABLE_PREFIX) and zipped with the model's own modelDescription.xml.
#
#   examples/fmu/bouncing_ball/build.sh [DIR]     # writes DIR/BouncingBall.fmu (default: here)
set -eu
dest="$(cd "${1:-$(dirname "$0")}" && pwd)"
cd "$(dirname "$0")"
src=reference-fmus
lib="$(mktemp -d)"
trap 'rm -rf "$lib"' EXIT
${CC:-cc} -shared -fPIC -O2 -std=gnu99 -DFMI_VERSION=2 -DDISABLE_PREFIX \
  -I"$src/include" -I"$src/BouncingBall" -o "$lib/BouncingBall.so" \
  "$src/BouncingBall/model.c" "$src/src/fmi2Functions.c" "$src/src/cosimulation.c" -lm
LIB="$lib/BouncingBall.so" FMU="$dest/BouncingBall.fmu" python3 - <<'PY'
import os, zipfile
with zipfile.ZipFile(os.environ["FMU"], "w", zipfile.ZIP_DEFLATED) as z:
    z.write("reference-fmus/BouncingBall/FMI2.xml", "modelDescription.xml")
    z.write(os.environ["LIB"], "binaries/linux64/BouncingBall.so")
PY
echo "wrote $dest/BouncingBall.fmu"
