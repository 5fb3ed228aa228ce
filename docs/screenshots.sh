#!/bin/sh
# Regenerates docs/rerun_trial.png and docs/rerun_campaign.png headless: the viewer renders with
# Mesa's software Vulkan (llvmpipe) under Xvfb and saves its own screenshot (--screenshot-to;
# capturing the Xvfb window instead comes back black). Needs: apt-get install xvfb
# mesa-vulkan-drivers libvulkan1 libxkbcommon-x11-0; pip install rerun-sdk==0.36.3 pillow;
# a savme built with --features rerun as $SAVME. Takes minutes with a debug build.
set -eu
SAVME=${SAVME:-target/release/savme}
T=$(mktemp -d)
shot() { # shot FILE.rrd OUT.png
    xvfb-run -a -s "-screen 0 1600x1000x24" rerun "$1" --window-size 1600x1000 \
        --screenshot-to "$T/shot.png" >/dev/null 2>&1 || true # the viewer exits non-zero after the shot
    python3 -c "from PIL import Image; Image.open('$T/shot.png').convert('RGB').resize((1600, 1000), Image.LANCZOS).save('$2', optimize=True)"
}
# An FP of scenario 3: HF passes (1.86 m), LF at 2 Hz collides.
"$SAVME" simulate --scenario 3 --phi ego_speed=15,intruder_speed=8,time_offset=0 \
    --fidelity simulation_rate_hz=2 --record "$T/trial.rrd"
shot "$T/trial.rrd" docs/rerun_trial.png
# The campaign view alone (no trial recordings, so the viewer opens on it).
"$SAVME" reproduce --quiet --budgets 0.3 --iterations 60 --eval-iterations 10 --test-iterations 30 \
    --baseline-iterations 80 --baseline-test-iterations 40 --cost work --record-every 0 \
    --record-failures 0 --out "$T/out" --record "$T/campaign.rrd"
shot "$T/campaign.rrd" docs/rerun_campaign.png
rm -rf "$T"
