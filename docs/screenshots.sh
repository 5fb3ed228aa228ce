#!/bin/sh
# Regenerates docs/rerun_trial.png and docs/rerun_campaign.png headless: the pip viewer renders
# with Mesa's software Vulkan (llvmpipe) under Xvfb, its pointer moved out of the way (xdotool,
# once the viewer's window is up: Xvfb resets the pointer when its last client leaves);
# once the viewer holds all of a recording the screenshot is asked for over gRPC
# (`rerun.experimental.ViewerClient.save_screenshot`). The trial: savme streams it to the viewer
# (`--connect`). The campaign: savme writes the .rrd, then the viewer opens the file, as a user
# would (`rerun FILE.rrd`): it opens on the campaign view, following the end of the runtime
# timeline. (`rerun FILE --screenshot-to` takes the picture while the file is still loading;
# capturing the Xvfb window comes back black.) Needs: apt-get install xvfb xdotool
# mesa-vulkan-drivers libvulkan1 libxkbcommon-x11-0; pip install rerun-sdk==0.36.3 pillow; a
# savme built with --features rerun as $SAVME.
set -eu
SAVME=${SAVME:-target/release/savme}
PORT=${PORT:-9877}
URL="rerun+http://127.0.0.1:$PORT/proxy"
T=$(mktemp -d)
viewer() { # viewer [FILE]: starts the viewer (on FILE), listening on 127.0.0.1:$PORT
    xvfb-run -a -s "-screen 0 1600x1000x24" sh -c \
        '(sleep 8; xdotool mousemove 700 12) & exec rerun "$@"' rerun "$@" --bind 127.0.0.1 --port "$PORT" \
        --window-size 1600x1000 --hide-welcome-screen >"$T/viewer.log" 2>&1 &
    viewer=$!
}
save() { # save OUT.png: the screenshot, then the viewer stopped
    python3 -c "from rerun.experimental import ViewerClient; ViewerClient(url='$URL').save_screenshot('$T/shot.png')"
    sleep 5
    pkill -P "$viewer" 2>/dev/null || true # the viewer (a child of this xvfb-run)
    kill "$viewer" 2>/dev/null || true
    wait "$viewer" 2>/dev/null || true
    python3 -c "from PIL import Image; Image.open('$T/shot.png').convert('RGB').resize((1600, 1000), Image.LANCZOS).save('$1', optimize=True)"
}
shot() { # shot OUT.png COMMAND…: runs the savme COMMAND into a fresh viewer, then saves it
    out=$1
    shift
    viewer
    sleep 10
    "$SAVME" "$@" --connect "$URL"
    sleep 10 # the viewer ingests what savme flushed
    save "$out"
}
fileshot() { # fileshot OUT.png COMMAND…: runs the savme COMMAND into a file, opens it, saves
    out=$1
    shift
    "$SAVME" "$@" --record "$T/file.rrd"
    viewer "$T/file.rrd"
    sleep 60 # the viewer loads the file
    save "$out"
}
# An FN of scenario 3 (evaluation trial #7 of the campaign below): HF collides at 5.30 s; LF
# (4 Hz, no lighting, shadows or shot noise, 89 m view, ...) passes at 0.02 m.
shot docs/rerun_trial.png simulate --scenario intruder_turns_left_across_ego \
    --phi ego_speed=19.052481924886354,intruder_speed=7.292077626030616,time_offset=0.837683984724011 \
    --fidelity simulation_rate_hz=4,camera_disable_lighting=true,camera_disable_shadows=true,camera_disable_depth_of_field=true,camera_disable_shot_noise=true,camera_view_distance_m=89.45526620968404,camera_near_clipping_m=0.40258804848037105,lidar_disable_shot_noise=true,lidar_disable_ambient_effects=true,lidar_subsample_count=1,lidar_near_clipping_m=0.2540158859886383
# The campaign with its default trial recordings (`--cost work`: deterministic, so its evaluation
# trial #7 is the FN above).
fileshot docs/rerun_campaign.png reproduce --quiet --budgets 0.3 --iterations 60 \
    --eval-iterations 10 --test-iterations 30 --baseline-iterations 80 \
    --baseline-test-iterations 40 --cost work --out "$T/out"
rm -rf "$T"
