"""A minimal Foxglove WebSocket client (protocol ``foxglove.sdk.v1``: JSON
control messages, binary message data) for tests: connect to a view,
subscribe to every channel it advertises, and keep what arrives, per topic
(JSON channels decoded, protobuf ones as bytes). Runs in a thread; retries
the connection until the server is up. Only connects to the address given
(localhost in this project's tests)."""
from __future__ import annotations

import json
import struct
import threading
import time


class FoxgloveClient:
    def __init__(self, url: str, connect_timeout_s: float = 60.0):
        self.url = url
        self.connect_timeout_s = connect_timeout_s
        self.channels: dict[int, dict] = {}            # channel id -> advertised channel
        self.messages: dict[str, list] = {}            # topic -> payloads (dict for JSON, bytes otherwise)
        self.server_info: dict | None = None
        self.error: str | None = None
        self._subs: dict[int, int] = {}                # subscription id -> channel id
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def __enter__(self) -> "FoxgloveClient":
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join(timeout=10)

    def count(self, topic: str) -> int:
        with self._lock:
            return len(self.messages.get(topic, []))

    def _run(self) -> None:
        from websockets.sync.client import connect
        deadline = time.monotonic() + self.connect_timeout_s
        while not self._stop.is_set():
            try:
                with connect(self.url, subprotocols=["foxglove.sdk.v1"], open_timeout=5) as ws:
                    self._receive(ws)
                return
            except OSError as exc:                       # server not up yet
                if time.monotonic() > deadline:
                    self.error = f"could not connect to {self.url}: {exc}"
                    return
                time.sleep(0.3)

    def _receive(self, ws) -> None:
        while not self._stop.is_set():
            try:
                msg = ws.recv(timeout=0.2)
            except TimeoutError:
                continue
            except Exception:                             # server gone
                return
            if isinstance(msg, str):
                self._control(ws, json.loads(msg))
            elif msg and msg[0] == 0x01:                  # message data: sub id u32, log time u64, payload
                sub_id, _t = struct.unpack_from("<IQ", msg, 1)
                ch = self.channels.get(self._subs.get(sub_id, -1))
                if ch is not None:
                    payload = bytes(msg[13:])
                    value = json.loads(payload) if ch.get("encoding") == "json" else payload
                    with self._lock:
                        self.messages.setdefault(ch["topic"], []).append(value)

    def _control(self, ws, d: dict) -> None:
        if d.get("op") == "serverInfo":
            self.server_info = d
        elif d.get("op") == "advertise":
            new = []
            for ch in d.get("channels", []):
                self.channels[ch["id"]] = ch
                sub_id = len(self._subs)
                self._subs[sub_id] = ch["id"]
                new.append({"id": sub_id, "channelId": ch["id"]})
            if new:
                ws.send(json.dumps({"op": "subscribe", "subscriptions": new}))
