#!/bin/sh
# Regenerates docs/rerun_trial.png and docs/rerun_campaign.png headless: the pip viewer renders
# with Mesa's software Vulkan (llvmpipe) under Xvfb; savme streams each recording to it
# (`--connect`), and once savme has finished (so the viewer holds all of it) the screenshot is
# asked for over gRPC (`rerun.experimental.ViewerClient.save_screenshot`). Opening the .rrd with
# `rerun FILE --screenshot-to` instead takes the picture while the file is still loading, at a
# random point of playback (curves half drawn, the summary empty); capturing the Xvfb window comes
# back black. Needs: apt-get install xvfb mesa-vulkan-drivers libvulkan1 libxkbcommon-x11-0;
# pip install rerun-sdk==0.36.3 pillow; a savme built with --features rerun as $SAVME.
set -eu
SAVME=${SAVME:-target/release/savme}
PORT=${PORT:-9877}
URL="rerun+http://127.0.0.1:$PORT/proxy"
T=$(mktemp -d)
shot() { # shot OUT.png COMMAND…: runs the savme COMMAND into a fresh viewer, then saves it
    out=$1
    shift
    xvfb-run -a -s "-screen 0 1600x1000x24" rerun --port "$PORT" --window-size 1600x1000 \
        --hide-welcome-screen >"$T/viewer.log" 2>&1 &
    viewer=$!
    sleep 10
    "$SAVME" "$@" --connect "$URL"
    sleep 10 # the viewer ingests what savme flushed
    python3 -c "from rerun.experimental import ViewerClient; ViewerClient(url='$URL').save_screenshot('$T/shot.png')"
    sleep 5
    pkill -P "$viewer" 2>/dev/null || true # the viewer (a child of this xvfb-run)
    kill "$viewer" 2>/dev/null || true
    wait "$viewer" 2>/dev/null || true
    python3 -c "from PIL import Image; Image.open('$T/shot.png').convert('RGB').resize((1600, 1000), Image.LANCZOS).save('$out', optimize=True)"
}
# An FP of scenario 3: HF passes (1.86 m), LF at 2 Hz collides.
shot docs/rerun_trial.png simulate --scenario 3 --phi ego_speed=15,intruder_speed=8,time_offset=0 \
    --fidelity simulation_rate_hz=2
# The campaign view alone (no trial recordings, so the viewer opens on it).
shot docs/rerun_campaign.png reproduce --quiet --budgets 0.3 --iterations 60 --eval-iterations 10 \
    --test-iterations 30 --baseline-iterations 80 --baseline-test-iterations 40 --cost work \
    --record-every 0 --record-failures 0 --out "$T/out"
rm -rf "$T"
