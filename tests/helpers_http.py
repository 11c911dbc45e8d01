"""A JSON-over-HTTP server on loopback for the tests of HTTP clients (VLM, image generation)."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

#: ``answer(request_body, script_entry) -> (status, response bytes, delay in seconds)``
Answer = Callable[[dict, tuple], tuple[int, bytes, float]]


class LoopbackServer:
    """Answers each POST with the next entry of a script (the last one repeats), through ``answer``;
    records every request (path, JSON body, Authorization header). Use as a context manager.

    :param script: one entry per expected request, in the shape ``answer`` reads
    :param answer: turns the request body and the entry into the HTTP answer
    """

    def __init__(self, script: list[tuple], answer: Answer):
        self.script, self.requests = list(script), []
        owner = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self):  # noqa: N802 (http.server API)
                body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
                owner.requests.append({"path": self.path, "body": body, "auth": self.headers.get("Authorization")})
                entry = owner.script.pop(0) if len(owner.script) > 1 else owner.script[0]
                status, data, delay = answer(body, entry)
                time.sleep(delay)
                try:
                    self.send_response(status)
                    self.send_header("Content-Type", "application/json")
                    self.send_header("Content-Length", str(len(data)))
                    self.end_headers()
                    self.wfile.write(data)
                except (BrokenPipeError, ConnectionResetError):
                    pass  # the client gave up (timeout tests)

            def log_message(self, *args):
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.server.daemon_threads = True
        self.thread = threading.Thread(target=self.server.serve_forever, args=(0.05,), daemon=True)

    @property
    def root(self) -> str:
        return f"http://127.0.0.1:{self.server.server_address[1]}"

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.server.shutdown()
        self.server.server_close()
