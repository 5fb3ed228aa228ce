#!/usr/bin/env python3
"""Which recording a running rerun 0.36 viewer shows: asks its ViewerControlService
(GetViewerState, on the viewer's gRPC port) and prints the page, the active recording and every
open recording as (application id, recording id).

How the live case of the campaign view was checked (2026-11-26): the pip viewer
(`rerun-sdk==0.36.3`) under Xvfb as in docs/screenshots.sh (`rerun --bind 127.0.0.1 --port
9877 ...`), then several campaigns into that one viewer, each followed by this script:

    savme reproduce --budgets 0.3 --iterations 20 --eval-iterations 5 --test-iterations 10 \\
        --baseline-iterations 20 --baseline-test-iterations 10 --cost work \\
        --record-failures 3 --record-every 30 --seed S --out DIR \\
        --connect rerun+http://127.0.0.1:9877/proxy
    python3 docs/viewer_state.py 9877     # active: ('savme-campaign - seed S - ...', ...)

Needs `pip install grpcio`. The request is empty and the answer is decoded by hand (protobuf
wire format: url = 1, active_store_id = 2, recordings = 3 with store_id = 1; a StoreId has
recording_id = 2 and application_id = 3 holding the id at 1).
"""
import sys

import grpc


def varint(b, i):
    shift = result = 0
    while True:
        c = b[i]
        i += 1
        result |= (c & 0x7F) << shift
        shift += 7
        if c < 0x80:
            return result, i


def fields(buf):
    """(tag, value) of every varint or length-delimited field of a message."""
    i, out = 0, []
    while i < len(buf):
        key, i = varint(buf, i)
        tag, wire = key >> 3, key & 7
        if wire == 0:
            value, i = varint(buf, i)
        elif wire == 2:
            n, i = varint(buf, i)
            value, i = buf[i:i + n], i + n
        else:
            raise ValueError(f"wire type {wire} not expected")
        out.append((tag, value))
    return out


def store(buf):
    f = dict(fields(buf))
    app = dict(fields(f.get(3, b""))).get(1, b"").decode()
    return app, f.get(2, b"").decode()


def main():
    port = sys.argv[1] if len(sys.argv) > 1 else "9876"
    channel = grpc.insecure_channel(f"127.0.0.1:{port}")
    call = channel.unary_unary(
        "/rerun.sdk_comms.v1alpha1.ViewerControlService/GetViewerState",
        request_serializer=lambda x: x,
        response_deserializer=lambda x: x,
    )
    for tag, value in fields(call(b"", timeout=30)):
        if tag == 1:
            print("page:", value.decode())
        elif tag == 2:
            print("active:", store(value))
        elif tag == 3:
            print("recording:", store(dict(fields(value)).get(1, b"")))


if __name__ == "__main__":
    main()
